// COLLADA texture coordinate bindings, read from the document itself (pugixml): a material's
// diffuse <texture texcoord="CHANNEL1"/> names a semantic, and each <instance_material> binds
// that semantic to a TEXCOORD set with <bind_vertex_input semantic="CHANNEL1"
// input_semantic="TEXCOORD" input_set="0"/>. Assimp 5.2 guesses the set from the digit in the
// semantic's name instead, which reads a uv set that may not exist. Used by importers/collada.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace meshmux {

// Material (by id and by name) → the TEXCOORD set its diffuse texture is bound to. Materials
// without a binding are absent. `xml` is the whole document; a document that does not parse
// gives an empty map (Assimp reports the parse error). O(document size).
std::map<std::string, unsigned> collada_diffuse_uv_sets(const std::vector<uint8_t>& xml);

}  // namespace meshmux
