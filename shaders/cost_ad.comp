#version 450
// Matching cost AD: C(x,y,d) = min(|L(x,y) - R(x - d,y)|, 63), x - d clamped into the row (see
// ips/e3d/matching_cost.hpp), written into the cost volume (cost_volume.glsl), for pc's [x_begin, x_end) x
// [y_begin, y_end) (the image). One workgroup (= one subgroup) per row; lane l owns disparities l*K .. l*K+K-1 and the right greys slide by one disparity per pixel (one load and one
// shuffle per step).
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
    const int l = int(grey(false, y, x));
    uint c[K];
    [[unroll]] for (int k = 0; k < K; ++k) c[k] = k0 + k < pc.num_disp ? uint(min(abs(l - int(window[k])), 63)) : 255u;
    storeCosts(y, x, c);
  }
}
