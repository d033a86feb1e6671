#version 450
// Matching cost of Mutual Information with the 256 x 256 table T learnt by mi_table.comp (ips/e3d/matching_cost.hpp),
// written into the cost volume (cost_volume.glsl): with MI_WINDOW 1 the pixelwise C(x,y,d) = T[L(x,y)][R(x - d,y)],
// x - d clamped into the row; with MI_WINDOW 3 the mean of T over the 3x3 windows (cost_window3x3.glsl, as SAD).
// The second match (MIRROR) uses the transposed table. One table per region of the image
// (SgmParams::mi_region_columns x mi_region_rows): one dispatch per region, its table bound at the region's dynamic
// offset, its pixels pc's [x_begin, x_end) x [y_begin, y_end). One workgroup (= one subgroup) per row (pixelwise) or
// per E3D_WINDOW_ROWS rows (window); lane l owns disparities l*K .. l*K+K-1 and the right greys slide by one
// disparity per pixel.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = E3D_SPEC_SUBGROUP_SIZE) in;
layout(constant_id = E3D_SPEC_LANE_DISPARITIES) const int K = 16;
layout(constant_id = E3D_SPEC_MIRROR) const bool MIRROR = false;
layout(constant_id = E3D_SPEC_MI_WINDOW) const int MI_WINDOW = 1;
#include "cost_volume.glsl"
// The region's table, one byte per entry (a uniform buffer: lavapipe gathers from it without a loop over the lanes,
// and the same code reads each region's table at its own offset).
layout(std140, binding = 5) uniform Table { uvec4 table[4096]; };

uint tableCost(uint left, uint right) {
  const uint e = MIRROR ? (right << 8) | left : (left << 8) | right;
  return (table[e >> 4][(e >> 2) & 3u] >> ((e & 3u) << 3)) & 0xFFu;
}
#define WINDOW_PAIR_COST(l, r) tableCost(l, r)
#include "cost_window3x3.glsl"

void pixelCosts() {
  const uint lane = gl_SubgroupInvocationID;
  const int y = pc.y_begin + int(gl_WorkGroupID.x);
  const int k0 = int(lane) * K;
  uint window[K];  // R(x - d_min - k0 - k)
  [[unroll]] for (int k = 0; k < K; ++k) window[k] = grey(true, y, pc.x_begin - pc.min_disp - k0 - k);
  for (int x = pc.x_begin; x < pc.x_end; ++x) {
    if (x > pc.x_begin) {
      const uint carried = subgroupShuffleUp(window[K - 1], 1u);
      [[unroll]] for (int k = K - 1; k > 0; --k) window[k] = window[k - 1];
      const uint fresh = grey(true, y, x - pc.min_disp);
      window[0] = lane == 0u ? fresh : carried;
    }
    const uint l = grey(false, y, x);
    uint c[K];
    [[unroll]] for (int k = 0; k < K; ++k) c[k] = k0 + k < pc.num_disp ? tableCost(l, window[k]) : 255u;
    storeCosts(y, x, c);
  }
}

void main() {
  // A specialisation constant: the pipeline holds one of the two.
  if (MI_WINDOW == 3)
    window3x3Costs();
  else
    pixelCosts();
}
