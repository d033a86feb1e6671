#version 450
// Census 5x5 of both rectified images: 24-bit code, bit set when the neighbour is darker than the centre,
// neighbours clamped to the image (row-major order of the 24 neighbours, most significant bit first).
// Each invocation computes a column of STRIP pixels, sliding a 5x5 window down (5 new pixels per output instead
// of 25: on lavapipe every load whose address differs per lane is a loop over the lanes). z = 0 left, z = 1 right.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "e3d_common.glsl"
layout(local_size_x = E3D_GROUP_SIZE) in;
const int STRIP = E3D_STRIP;
#define E3D_IMAGE_PARAMS
#include "ips/e3d_shaders/image_stages.h"
// The 8-bit images, four pixels to a word, read as texels.
layout(binding = 0, r32ui) uniform readonly uimageBuffer image_left;
layout(binding = 1, r32ui) uniform readonly uimageBuffer image_right;
layout(std430, binding = 2) writeonly buffer CensusLeft { uint census_left[]; };
layout(std430, binding = 3) writeonly buffer CensusRight { uint census_right[]; };

uint pixelAt(bool right, int x, int y) {
  const int idx = clamp(y, 0, pc.height - 1) * pc.width + clamp(x, 0, pc.width - 1);
  const uint word = right ? imageLoad(image_right, idx >> 2).x : imageLoad(image_left, idx >> 2).x;
  return (word >> ((idx & 3) << 3)) & 0xFFu;
}

void main() {
  const int x = int(gl_GlobalInvocationID.x);
  const int y0 = int(gl_GlobalInvocationID.y) * STRIP;
  if (x >= pc.width || y0 >= pc.height) return;
  const bool right = gl_GlobalInvocationID.z == 1u;
  uint window[5][5];  // [row][column], rows y - 2 .. y + 2 of the current output row y
  [[unroll]] for (int r = 0; r < 4; ++r)
    [[unroll]] for (int c = 0; c < 5; ++c) window[r + 1][c] = pixelAt(right, x + c - 2, y0 + r - 2);
  [[unroll]] for (int i = 0; i < STRIP; ++i) {
    [[unroll]] for (int r = 0; r < 4; ++r)
      [[unroll]] for (int c = 0; c < 5; ++c) window[r][c] = window[r + 1][c];
    [[unroll]] for (int c = 0; c < 5; ++c) window[4][c] = pixelAt(right, x + c - 2, y0 + i + 2);
    const uint centre = window[2][2];
    uint code = 0u;
    [[unroll]] for (int r = 0; r < 5; ++r)
      [[unroll]] for (int c = 0; c < 5; ++c) {
        if (r == 2 && c == 2) continue;
        code = (code << 1) | (window[r][c] < centre ? 1u : 0u);
      }
    const int y = y0 + i;
    if (y < pc.height) {
      if (right) census_right[y * pc.width + x] = code;
      else census_left[y * pc.width + x] = code;
    }
  }
}
