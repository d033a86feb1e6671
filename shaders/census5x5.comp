#version 450
// Census 5x5 of both rectified images: 24-bit code, bit set when the neighbour is darker than the centre,
// neighbours clamped to the image. One invocation per pixel; z = 0 left, z = 1 right.
#extension GL_GOOGLE_include_directive : require
#include "e3d_common.glsl"
layout(local_size_x = 16, local_size_y = 8) in;
layout(push_constant) uniform Params { int width; int height; } pc;
layout(std430, binding = 0) readonly buffer ImageLeft { uint image_left[]; };
layout(std430, binding = 1) readonly buffer ImageRight { uint image_right[]; };
layout(std430, binding = 2) writeonly buffer CensusLeft { uint census_left[]; };
layout(std430, binding = 3) writeonly buffer CensusRight { uint census_right[]; };

uint pixelAt(bool right, int x, int y) {
  int idx = clamp(y, 0, pc.height - 1) * pc.width + clamp(x, 0, pc.width - 1);
  return right ? E3D_PIXEL(image_right, idx) : E3D_PIXEL(image_left, idx);
}

void main() {
  int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= pc.width || y >= pc.height) return;
  bool right = gl_GlobalInvocationID.z == 1u;
  uint c = pixelAt(right, x, y);
  uint code = 0u;
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx) {
      if (dx == 0 && dy == 0) continue;
      code = (code << 1) | (pixelAt(right, x + dx, y + dy) < c ? 1u : 0u);
    }
  if (right) census_right[y * pc.width + x] = code;
  else census_left[y * pc.width + x] = code;
}
