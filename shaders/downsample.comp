#version 450
// One pyramid step for the hierarchical Mutual Information: each pixel the mean of a 2x2 block, rounded
// ((sum + 2) / 4; the last column and row repeated for odd sizes), both images (z = 0 left, 1 right). Each
// invocation writes one word = 4 pixels of the half-size image (ips::e3d::halfSize).
#extension GL_GOOGLE_include_directive : require
#include "e3d_common.glsl"
layout(local_size_x = E3D_GROUP_SIZE) in;
#define E3D_DOWNSAMPLE_PARAMS
#include "ips/e3d_shaders/image_stages.h"
layout(binding = 0, r32ui) uniform readonly uimageBuffer source_left;
layout(binding = 1, r32ui) uniform readonly uimageBuffer source_right;
layout(std430, binding = 2) writeonly buffer HalfLeft { uint half_left[]; };
layout(std430, binding = 3) writeonly buffer HalfRight { uint half_right[]; };

uint grey(bool right, int y, int x) {
  const int idx = min(y, pc.height - 1) * pc.width + min(x, pc.width - 1);
  const uint word = right ? imageLoad(source_right, idx >> 2).x : imageLoad(source_left, idx >> 2).x;
  return (word >> ((idx & 3) << 3)) & 0xFFu;
}

void main() {
  const int word = int(gl_GlobalInvocationID.x);
  const int n = pc.half_width * pc.half_height;
  if (4 * word >= n) return;
  const bool right = gl_GlobalInvocationID.z == 1u;
  uint packed = 0u;
  for (int i = 0; i < 4; ++i) {
    const int idx = min(4 * word + i, n - 1);
    const int y = idx / pc.half_width, x = idx - y * pc.half_width;
    const uint sum = grey(right, 2 * y, 2 * x) + grey(right, 2 * y, 2 * x + 1) + grey(right, 2 * y + 1, 2 * x) +
                     grey(right, 2 * y + 1, 2 * x + 1);
    packed |= ((sum + 2u) / 4u) << (8 * i);
  }
  if (right) half_right[word] = packed;
  else half_left[word] = packed;
}
