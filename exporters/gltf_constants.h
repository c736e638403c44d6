// The GL enums a glTF 2.0 file names by number, declared once for the glTF writers: accessor
// component types (glTF 2.0 §3.6.2.2, accessor.componentType) and buffer view targets (§3.6.1,
// bufferView.target).
#pragma once

namespace meshmux::gltf_enum {

constexpr int kByte = 5120;
constexpr int kUnsignedByte = 5121;
constexpr int kShort = 5122;
constexpr int kUnsignedShort = 5123;
constexpr int kUnsignedInt = 5125;
constexpr int kFloat = 5126;
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

}  // namespace meshmux::gltf_enum
