// COLLADA 1.4.1 specification, "bind_vertex_input" and "instance_material" (chapter 5/8): the
// semantic of a <texture texcoord=...> is resolved through the bind_vertex_input elements of
// the instance_material that binds the material to geometry.
#include "importers/collada_bindings.h"

#include <cstdlib>
#include <cstring>
#include <pugixml.hpp>

namespace meshmux {

namespace {

// "#id" → "id".
std::string fragment(const char* url) { return url && url[0] == '#' ? url + 1 : std::string(); }

// Descendants named `name` (namespaces ignored: COLLADA files use the default namespace).
void collect(const pugi::xml_node& node, const char* name, std::vector<pugi::xml_node>& out) {
  for (pugi::xml_node n = node.first_child(); n;) {
    if (n.type() == pugi::node_element && std::strcmp(n.name(), name) == 0) out.push_back(n);
    if (n.first_child()) {
      n = n.first_child();
      continue;
    }
    while (n && !n.next_sibling() && n != node) n = n.parent();
    if (!n || n == node) break;
    n = n.next_sibling();
  }
}

}  // namespace

std::map<std::string, ColladaMaterialInfo> collada_material_info(const std::vector<uint8_t>& xml) {
  std::map<std::string, ColladaMaterialInfo> out;
  pugi::xml_document doc;
  // No entity expansion of any kind: pugixml does not read DTDs or external entities.
  if (!doc.load_buffer(xml.data(), xml.size(), pugi::parse_default & ~pugi::parse_doctype))
    return out;
  // effect id → the texcoord semantic of its diffuse texture, and its shininess.
  std::map<std::string, std::string> effect_semantic;
  std::map<std::string, float> effect_shininess;
  std::map<std::string, bool> effect_diffuse;
  std::vector<pugi::xml_node> effects;
  collect(doc, "effect", effects);
  for (const pugi::xml_node& e : effects) {
    std::vector<pugi::xml_node> diffuse;
    collect(e, "diffuse", diffuse);
    effect_diffuse[e.attribute("id").value()] = !diffuse.empty();
    for (const pugi::xml_node& d : diffuse)
      if (pugi::xml_node t = d.child("texture"); t && t.attribute("texcoord"))
        effect_semantic.emplace(e.attribute("id").value(), t.attribute("texcoord").value());
    for (const char* model : {"phong", "blinn"}) {
      std::vector<pugi::xml_node> shading;
      collect(e, model, shading);
      for (const pugi::xml_node& sh : shading)
        if (pugi::xml_node f = sh.child("shininess").child("float"))
          effect_shininess.emplace(e.attribute("id").value(), f.text().as_float(-1));
    }
  }
  // Each material: its info by id and by name; material id → {its effect's semantic, name}.
  std::map<std::string, std::pair<std::string, std::string>> material;
  std::vector<pugi::xml_node> materials;
  collect(doc, "material", materials);
  for (const pugi::xml_node& m : materials) {
    std::string effect = fragment(m.child("instance_effect").attribute("url").value());
    std::string id = m.attribute("id").value(), name = m.attribute("name").value();
    out[id].diffuse = effect_diffuse[effect];
    if (!name.empty()) out[name].diffuse = out[id].diffuse;
    if (auto sh = effect_shininess.find(effect); sh != effect_shininess.end()) {
      out[id].shininess = sh->second;
      if (!name.empty()) out[name].shininess = sh->second;
    }
    auto it = effect_semantic.find(effect);
    if (it != effect_semantic.end()) material[id] = {it->second, name};
  }
  // Each instance_material: the set its bind_vertex_input gives that semantic.
  std::vector<pugi::xml_node> instances;
  collect(doc, "instance_material", instances);
  for (const pugi::xml_node& im : instances) {
    std::string id = fragment(im.attribute("target").value());
    auto it = material.find(id);
    if (it == material.end()) continue;
    for (pugi::xml_node b = im.child("bind_vertex_input"); b;
         b = b.next_sibling("bind_vertex_input")) {
      if (it->second.first != b.attribute("semantic").value() ||
          std::strcmp(b.attribute("input_semantic").value(), "TEXCOORD") != 0)
        continue;
      int set = int(b.attribute("input_set").as_uint(0));
      if (out[id].uv_set < 0) out[id].uv_set = set;
      if (!it->second.second.empty() && out[it->second.second].uv_set < 0)
        out[it->second.second].uv_set = set;
    }
  }
  return out;
}

std::string repair_collada_images(const std::vector<uint8_t>& xml, std::vector<std::string>* ids) {
  pugi::xml_document doc;
  if (!doc.load_buffer(xml.data(), xml.size(), pugi::parse_default & ~pugi::parse_doctype))
    return "";
  std::vector<pugi::xml_node> images;
  collect(doc, "image", images);
  bool changed = false;
  for (pugi::xml_node& image : images) {
    // COLLADA 1.4 puts <init_from> right under <image>; 1.5 under <init_from><ref>.
    std::vector<pugi::xml_node> refs, data;
    collect(image, "init_from", refs);
    collect(image, "data", data);
    bool named = !data.empty();
    for (const pugi::xml_node& r : refs) named |= r.text().as_string()[0] != '\0' || r.child("ref");
    if (named) continue;
    std::string id = image.attribute("id").value();
    if (id.empty()) id = "unnamed image";
    for (pugi::xml_node& r : refs) image.remove_child(r);
    image.append_child("init_from").text().set(id.c_str());
    if (ids) ids->push_back(id);
    changed = true;
  }
  if (!changed) return "";
  std::ostringstream out;
  doc.save(out, "", pugi::format_raw);
  return out.str();
}

}  // namespace meshmux
