#version 450
// One SGM path direction (dx, dy): each workgroup is one subgroup and walks one line of the image in the
// path direction; lane l owns the K consecutive disparities l*K .. l*K+K-1 (the libSGM layout). Matching
// costs come from the cost slice of the volume (one byte per disparity, four to a word); the path cost L_r
// is written as one byte per disparity into this path's slice, which the winner-takes-all stage sums.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = E3D_SPEC_SUBGROUP_SIZE) in;               // = subgroup size
layout(constant_id = E3D_SPEC_LANE_DISPARITIES) const int K = 16;     // disparities per lane, a multiple of 4
layout(constant_id = E3D_SPEC_MIRROR) const bool MIRROR = false;  // the second match: the right image, bound as image_left, mirrored
#define E3D_AGGREGATE_PARAMS
#include "ips/e3d_shaders/match_stages.h"
layout(std430, binding = 0) readonly buffer ImageLeft { uint image_left[]; };
layout(std430, binding = 4) buffer Volume { uint v[]; } volume[E3D_MAX_CHUNKS];
// The same buffers seen as 16-byte words: when K is a multiple of 16 each lane moves whole uvec4s, which
// lavapipe turns into one access per lane instead of four (about 30 % faster there).
layout(std430, binding = 4) buffer Volume4 { uvec4 v4[]; } volume4[E3D_MAX_CHUNKS];
const bool VEC4 = (K % 16) == 0;

int wordIndex(int slice, int x, int y, out int chunk) {
  const int g = slice * pc.height + y;
  chunk = subgroupBroadcastFirst(g / pc.rows_per_chunk);  // uniform: lets the driver load one descriptor
  return (g - chunk * pc.rows_per_chunk) * pc.row_words + x * (K / 4) * int(gl_SubgroupSize) +
         int(gl_SubgroupInvocationID) * (K / 4);
}

void main() {
  const uint lane = gl_SubgroupInvocationID;
  const int line = int(gl_WorkGroupID.x);
  const int W = pc.width, H = pc.height;
  int x, y;
  if (pc.dy == 0) {
    y = line;
    x = pc.dx > 0 ? 0 : W - 1;
  } else if (pc.dx == 0) {
    x = line;
    y = pc.dy > 0 ? 0 : H - 1;
  } else if (line < W) {  // diagonal lines start on the first row of the walk, then on its first column
    x = line;
    y = pc.dy > 0 ? 0 : H - 1;
  } else {
    x = pc.dx > 0 ? 0 : W - 1;
    y = pc.dy > 0 ? line - W + 1 : H - 1 - (line - W + 1);
  }
  const int k0 = int(lane) * K;
  // Starting from L = 0 everywhere makes the first pixel of the line get L = C, as the recursion demands.
  uint prev[K];
  [[unroll]] for (int k = 0; k < K; ++k) prev[k] = 0u;
  uint prev_pixel = E3D_PIXEL(image_left, y * W + (MIRROR ? W - 1 - x : x));
  while (x >= 0 && x < W && y >= 0 && y < H) {
    const int idx = y * W + x;
    const uint pixel = E3D_PIXEL(image_left, y * W + (MIRROR ? W - 1 - x : x));
    uint cost[K];
    int cost_chunk;
    const int cost_base = wordIndex(pc.cost_slice, x, y, cost_chunk);
    [[unroll]] for (int j = 0; j < K / 4; ++j) {
      const uint word = VEC4 ? volume4[cost_chunk].v4[cost_base / 4 + j / 4][j % 4] : volume[cost_chunk].v[cost_base + j];
      cost[4 * j] = word & 0xFFu;
      cost[4 * j + 1] = (word >> 8) & 0xFFu;
      cost[4 * j + 2] = (word >> 16) & 0xFFu;
      cost[4 * j + 3] = word >> 24;
    }
    uint cur[K];
    {
      uint local_min = prev[0];
      [[unroll]] for (int k = 1; k < K; ++k) local_min = min(local_min, prev[k]);
      const uint m = subgroupMin(local_min);
      uint below = subgroupShuffleUp(prev[K - 1], 1u);
      uint above = subgroupShuffleDown(prev[0], 1u);
      if (lane == 0u) below = E3D_BIG;
      if (lane == gl_SubgroupSize - 1u) above = E3D_BIG;
      int p2 = pc.p2;
      if (pc.p2_slope > 0) p2 = max(pc.p1, pc.p2 - (pc.p2_slope * abs(int(pixel) - int(prev_pixel))) / 16);
      const uint jump = m + uint(p2);
      const uint P1 = uint(pc.p1);
      [[unroll]] for (int k = 0; k < K; ++k) {
        const uint lo = (k == 0) ? below : prev[k - 1];
        const uint hi = (k == K - 1) ? above : prev[k + 1];
        const uint best = min(min(prev[k], jump), min(lo, hi) + P1);
        // Padded disparities (cost 255) stay >= 255 and never win a minimum against real ones (<= 24 + P2).
        cur[k] = cost[k] + best - m;
      }
    }
    int chunk;
    const int base = wordIndex(pc.path, x, y, chunk);
    uint words[K / 4];
    [[unroll]] for (int j = 0; j < K / 4; ++j) {
      words[j] = min(cur[4 * j], 255u) | (min(cur[4 * j + 1], 255u) << 8) | (min(cur[4 * j + 2], 255u) << 16) |
                 (min(cur[4 * j + 3], 255u) << 24);
    }
    if (VEC4) {
      [[unroll]] for (int q = 0; q < K / 16; ++q)
        volume4[chunk].v4[base / 4 + q] = uvec4(words[4 * q], words[4 * q + 1], words[4 * q + 2], words[4 * q + 3]);
    } else {
      [[unroll]] for (int j = 0; j < K / 4; ++j) volume[chunk].v[base + j] = words[j];
    }
    [[unroll]] for (int k = 0; k < K; ++k) prev[k] = cur[k];
    prev_pixel = pixel;
    x += pc.dx;
    y += pc.dy;
  }
}
