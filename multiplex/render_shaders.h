// GLSL sources of the offscreen renderer (multiplex/render.h): one program with two shadings,
// the legacy Lambert one and the physically based one the web client's MeshStandardMaterial
// uses. Kept apart from render.cpp so the GL plumbing and the shading read alone.
#pragma once

namespace meshmux {

extern const char* const kRenderVertexShader;
extern const char* const kRenderFragmentShader;
extern const char* const kRenderDepthFragmentShader;

}  // namespace meshmux
