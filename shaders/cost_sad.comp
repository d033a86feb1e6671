#version 450
// Matching cost SAD: the mean absolute difference over the 3x3 window, C(x,y,d) =
// min((sum_{dy,dx} |L(x+dx,y+dy) - R(x-d+dx,y+dy)| + 4) / 9, 63), every column and row clamped into the image (see
// ips/e3d/matching_cost.hpp), written into the cost volume (cost_volume.glsl). One workgroup (= one subgroup) per
// row; lane l owns disparities l*K .. l*K+K-1. The right greys of the three rows slide by one disparity per pixel;
// R(x - d + 1) and R(x - d - 1) are the neighbouring disparities d - 1 and d + 1 (shuffles across lanes, and one
// extra load at each end of the range).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = E3D_SPEC_SUBGROUP_SIZE) in;
layout(constant_id = E3D_SPEC_LANE_DISPARITIES) const int K = 16;
layout(constant_id = E3D_SPEC_MIRROR) const bool MIRROR = false;
#include "cost_volume.glsl"

void main() {
  const uint lane = gl_SubgroupInvocationID;
  const uint last_lane = gl_SubgroupSize - 1u;
  const int y = int(gl_WorkGroupID.x);
  const int k0 = int(lane) * K;
  const int span = int(gl_SubgroupSize) * K;  // disparities held by the subgroup
  uint window[3][K];  // rows y - 1, y, y + 1: R(x - d_min - k0 - k)
  uint lgrey[3][3];   // rows y - 1 .. y + 1, columns x - 1 .. x + 1
  [[unroll]] for (int r = 0; r < 3; ++r) {
    [[unroll]] for (int k = 0; k < K; ++k) window[r][k] = grey(true, y + r - 1, -pc.min_disp - k0 - k);
    lgrey[r][1] = grey(false, y + r - 1, -1);
    lgrey[r][2] = grey(false, y + r - 1, 0);
  }
  for (int x = 0; x < pc.width; ++x) {
    uint sum[K];
    [[unroll]] for (int k = 0; k < K; ++k) sum[k] = 0u;
    [[unroll]] for (int r = 0; r < 3; ++r) {
      if (x > 0) {
        const uint carried = subgroupShuffleUp(window[r][K - 1], 1u);
        [[unroll]] for (int k = K - 1; k > 0; --k) window[r][k] = window[r][k - 1];
        const uint fresh = grey(true, y + r - 1, x - pc.min_disp);
        window[r][0] = lane == 0u ? fresh : carried;
      }
      lgrey[r][0] = lgrey[r][1];
      lgrey[r][1] = lgrey[r][2];
      lgrey[r][2] = grey(false, y + r - 1, x + 1);
      // disparity d - 1 (column x - d + 1) and d + 1 (column x - d - 1) beyond this lane's block
      const uint below_lane = subgroupShuffleUp(window[r][K - 1], 1u);
      const uint above_lane = subgroupShuffleDown(window[r][0], 1u);
      const uint below_range = grey(true, y + r - 1, x - pc.min_disp + 1);
      const uint above_range = grey(true, y + r - 1, x - pc.min_disp - span);
      const uint below = lane == 0u ? below_range : below_lane;
      const uint above = lane == last_lane ? above_range : above_lane;
      [[unroll]] for (int k = 0; k < K; ++k) {
        const uint at_plus = k == 0 ? below : window[r][k - 1];      // R(x - d + 1)
        const uint at_minus = k == K - 1 ? above : window[r][k + 1];  // R(x - d - 1)
        sum[k] += uint(abs(int(lgrey[r][0]) - int(at_minus)) + abs(int(lgrey[r][1]) - int(window[r][k])) +
                       abs(int(lgrey[r][2]) - int(at_plus)));
      }
    }
    uint c[K];
    [[unroll]] for (int k = 0; k < K; ++k) c[k] = k0 + k < pc.num_disp ? min((sum[k] + 4u) / 9u, 63u) : 255u;
    storeCosts(y, x, c);
  }
}
