#version 450
// Sums the path-cost slices, winner-takes-all with uniqueness test and equiangular subpixel offset for the
// left image, and the right image's disparity by the diagonal search min_k S(xr + d_min + k, y, k).
// One workgroup (= one subgroup) per row; lane l owns disparities l*K .. l*K+K-1 as in sgm_aggregate.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "e3d_common.glsl"
layout(local_size_x_id = E3D_SPEC_SUBGROUP_SIZE) in;
layout(constant_id = E3D_SPEC_LANE_DISPARITIES) const int K = 16;
// The second match (SgmParams::right_map "match"): its left map is stored mirrored back (binding 5 is then the
// right map) and no diagonal search runs; RIGHT_MAP: the diagonal search for the right map.
layout(constant_id = E3D_SPEC_MIRROR) const bool MIRROR = false;
layout(constant_id = E3D_SPEC_RIGHT_MAP) const bool RIGHT_MAP = true;
#define E3D_WTA_PARAMS
#include "ips/e3d_shaders/match_stages.h"
layout(std430, binding = 4) readonly buffer Volume { uint v[]; } volume[E3D_MAX_CHUNKS];
layout(std430, binding = 4) readonly buffer Volume4 { uvec4 v4[]; } volume4[E3D_MAX_CHUNKS];  // see sgm_aggregate
const bool VEC4 = (K % 16) == 0;
layout(std430, binding = 5) writeonly buffer DispLeft { int disp_left[]; };
layout(std430, binding = 6) writeonly buffer DispRight { int disp_right[]; };
shared uint best_right[E3D_MAX_WIDTH];  // (S << 8) | k, minimum over the diagonal

void main() {
  const uint lane = gl_SubgroupInvocationID;
  const uint SG = gl_SubgroupSize;
  const int y = int(gl_WorkGroupID.x);
  const int W = pc.width, H = pc.height;
  const int k0 = int(lane) * K;
  for (int x = int(lane); x < W; x += int(SG)) best_right[x] = 0xFFFFFFFFu;
  barrier();
  for (int x = 0; x < W; ++x) {
    uint s[K];
    [[unroll]] for (int k = 0; k < K; ++k) s[k] = 0u;
    for (int p = 0; p < pc.num_paths; ++p) {
      const int g = p * H + y;
      const int chunk = g / pc.rows_per_chunk;
      const int base = (g - chunk * pc.rows_per_chunk) * pc.row_words + x * (K / 4) * int(SG) + int(lane) * (K / 4);
      [[unroll]] for (int j = 0; j < K / 4; ++j) {
        const uint word = VEC4 ? volume4[chunk].v4[base / 4 + j / 4][j % 4] : volume[chunk].v[base + j];
        s[4 * j] += word & 0xFFu;
        s[4 * j + 1] += (word >> 8) & 0xFFu;
        s[4 * j + 2] += (word >> 16) & 0xFFu;
        s[4 * j + 3] += word >> 24;
      }
    }
    uint local_key = 0xFFFFFFFFu;
    [[unroll]] for (int k = 0; k < K; ++k)
      if (k0 + k < pc.num_disp) local_key = min(local_key, (s[k] << 8) | uint(k0 + k));
    const uint key = subgroupMin(local_key);
    const int best = int(key & 0xFFu);
    const uint best_cost = key >> 8;
    uint local_second = 0xFFFFFFFFu, local_c0 = 0u, local_c2 = 0u;
    [[unroll]] for (int k = 0; k < K; ++k) {
      const int d = k0 + k;
      if (d >= pc.num_disp) continue;
      if (abs(d - best) > 1) local_second = min(local_second, s[k]);
      if (d == best - 1) local_c0 = s[k];
      if (d == best + 1) local_c2 = s[k];
      const int xr = x - pc.min_disp - d;
      if (RIGHT_MAP && xr >= 0 && xr < W) atomicMin(best_right[xr], (s[k] << 8) | uint(d));
    }
    const uint second = subgroupMin(local_second);
    const int c0 = int(subgroupMax(local_c0)), c2 = int(subgroupMax(local_c2)), c1 = int(best_cost);
    if (lane == 0u) {
      bool valid = !(pc.uniqueness > 0 && second != 0xFFFFFFFFu && second * uint(100 - pc.uniqueness) < best_cost * 100u);
      int d16 = (pc.min_disp + best) * 16;
      if (pc.subpixel != 0 && best > 0 && best + 1 < pc.num_disp) {
        const int den = max(c0, c2) - c1;
        if (den > 0) {
          const int num = 8 * (c0 - c2);
          const int mag = (2 * abs(num) + den) / (2 * den);
          d16 += num < 0 ? -mag : mag;
        }
      }
      disp_left[y * W + (MIRROR ? W - 1 - x : x)] = valid ? d16 : E3D_INVALID;
    }
  }
  barrier();
  for (int x = int(lane); RIGHT_MAP && x < W; x += int(SG)) {
    const uint key = best_right[x];
    disp_right[y * W + x] = key == 0xFFFFFFFFu ? E3D_INVALID : (pc.min_disp + int(key & 0xFFu)) * 16;
  }
}
