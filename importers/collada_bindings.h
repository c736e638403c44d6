// COLLADA texture coordinate bindings, read from the document itself (pugixml): a material's
// diffuse <texture texcoord="CHANNEL1"/> names a semantic, and each <instance_material> binds
// that semantic to a TEXCOORD set with <bind_vertex_input semantic="CHANNEL1"
// input_semantic="TEXCOORD" input_set="0"/>. Assimp 5.2 guesses the set from the digit in the
// semantic's name instead, which reads a uv set that may not exist. Also the <shininess> of
// phong and blinn effects, which Assimp 5.2 reports as 0, and whether an effect has a <diffuse>
// at all (Assimp 5.2 makes a missing one 0.6 grey). Used by importers/collada.
#pragma once

#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace meshmux {

// What the document says of a material that Assimp 5.2 loses.
struct ColladaMaterialInfo {
  int uv_set = -1;       // the TEXCOORD set its diffuse texture is bound to (-1: no binding)
  float shininess = -1;  // the Blinn-Phong exponent of a <phong>/<blinn> effect (-1: none)
  bool diffuse = false;  // its effect has a <diffuse> (a colour or a texture)
};

// Material (by id and by name) → what the document says of it. `xml` is the whole document; a
// document that does not parse gives an empty map (Assimp reports the parse error).
// O(document size).
std::map<std::string, ColladaMaterialInfo> collada_material_info(const std::vector<uint8_t>& xml);

// The <image> elements Assimp 5.2 rejects the whole document for ("Invalid texture, no data or
// file reference given"): no <init_from> with text and no <data> (an exporter commented the
// file out, or wrote only an id). Each gets <init_from>ID</init_from> naming its own id, so the
// document loads and that texture alone is reported missing (the material keeps its colour).
// Returns the repaired document, or "" when nothing needed repair; `ids` gets the images'
// ids. O(document size).
std::string repair_collada_images(const std::vector<uint8_t>& xml, std::vector<std::string>* ids);

}  // namespace meshmux
