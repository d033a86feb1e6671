#version 450
// One SGM path direction (dx, dy): each workgroup is one subgroup and walks one line of the image in the
// path direction; lane l owns the K consecutive disparities l*K .. l*K+K-1 (the libSGM layout). Matching
// costs are computed on the fly from the census codes; the path cost L_r is written as one byte per
// disparity into this path's slice of the volume, which the winner-takes-all stage sums.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = 0) in;               // = subgroup size
layout(constant_id = 1) const int K = 16;     // disparities per lane, a multiple of 4
layout(push_constant) uniform Params {
  int width, height, num_disp, min_disp;
  int p1, p2, p2_slope, path;
  int dx, dy, rows_per_chunk, row_words;      // volume addressing: row g = path * height + y
} pc;
layout(std430, binding = 0) readonly buffer ImageLeft { uint image_left[]; };
layout(std430, binding = 2) readonly buffer CensusLeft { uint census_left[]; };
layout(std430, binding = 3) readonly buffer CensusRight { uint census_right[]; };
layout(std430, binding = 4) writeonly buffer Volume { uint v[]; } volume[E3D_MAX_CHUNKS];

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
  uint prev[K];
  for (int k = 0; k < K; ++k) prev[k] = E3D_BIG;
  bool first = true;
  uint prev_pixel = 0u;
  while (x >= 0 && x < W && y >= 0 && y < H) {
    const int idx = y * W + x;
    const uint cl = census_left[idx];
    const uint pixel = E3D_PIXEL(image_left, idx);
    uint cur[K];
    if (first) {
      for (int k = 0; k < K; ++k) {
        int xr = clamp(x - (pc.min_disp + k0 + k), 0, W - 1);
        cur[k] = (k0 + k < pc.num_disp) ? uint(bitCount(cl ^ census_right[y * W + xr])) : E3D_BIG;
      }
    } else {
      uint local_min = prev[0];
      for (int k = 1; k < K; ++k) local_min = min(local_min, prev[k]);
      const uint m = subgroupMin(local_min);
      uint below = subgroupShuffleUp(prev[K - 1], 1u);
      uint above = subgroupShuffleDown(prev[0], 1u);
      if (lane == 0u) below = E3D_BIG;
      if (lane == gl_SubgroupSize - 1u) above = E3D_BIG;
      int p2 = pc.p2;
      if (pc.p2_slope > 0) p2 = max(pc.p1, pc.p2 - (pc.p2_slope * abs(int(pixel) - int(prev_pixel))) / 16);
      const uint jump = m + uint(p2);
      const uint P1 = uint(pc.p1);
      for (int k = 0; k < K; ++k) {
        const uint lo = (k == 0) ? below : prev[k - 1];
        const uint hi = (k == K - 1) ? above : prev[k + 1];
        const uint best = min(min(prev[k], jump), min(lo, hi) + P1);
        const int xr = clamp(x - (pc.min_disp + k0 + k), 0, W - 1);
        const uint c = uint(bitCount(cl ^ census_right[y * W + xr]));
        cur[k] = (k0 + k < pc.num_disp) ? c + best - m : E3D_BIG;
      }
    }
    const int g = pc.path * H + y;
    const int chunk = g / pc.rows_per_chunk;
    const int base = (g - chunk * pc.rows_per_chunk) * pc.row_words + x * (K / 4) * int(gl_SubgroupSize) + int(lane) * (K / 4);
    for (int j = 0; j < K / 4; ++j) {
      uint word = min(cur[4 * j], 255u) | (min(cur[4 * j + 1], 255u) << 8) | (min(cur[4 * j + 2], 255u) << 16) |
                  (min(cur[4 * j + 3], 255u) << 24);
      volume[chunk].v[base + j] = word;
    }
    for (int k = 0; k < K; ++k) prev[k] = cur[k];
    prev_pixel = pixel;
    first = false;
    x += pc.dx;
    y += pc.dy;
  }
}
