#version 450
// Matching cost of the census transform: C(x,y,k) = popcount(census_left(x,y) ^ census_right(x - d_min - k, y))
// (x - d clamped into the image), written once into the cost slice of the volume, one byte per disparity,
// in the lane layout of sgm_aggregate (lane l owns disparities l*K .. l*K+K-1). Other cost functions write
// the same slice (the cost stage is pluggable). One workgroup (= one subgroup) per row: the census values of
// the right image slide by one disparity per pixel, so each step loads one value and shuffles the rest.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = E3D_SPEC_SUBGROUP_SIZE) in;
layout(constant_id = E3D_SPEC_LANE_DISPARITIES) const int K = 16;
// The second match, right to left (SgmParams::right_map "match"): the census images are bound swapped and read
// mirrored (popcount(a ^ b) does not change when both codes mirror their bits, so the codes are used as they are).
layout(constant_id = E3D_SPEC_MIRROR) const bool MIRROR = false;
#define E3D_CENSUS_COST_PARAMS
#include "ips/e3d_shaders/match_stages.h"
layout(std430, binding = 2) readonly buffer CensusLeft { uint census_left[]; };
layout(std430, binding = 3) readonly buffer CensusRight { uint census_right[]; };
layout(std430, binding = 4) writeonly buffer Volume { uint v[]; } volume[E3D_MAX_CHUNKS];

int column(int x) { return MIRROR ? pc.width - 1 - x : x; }

void main() {
  const uint lane = gl_SubgroupInvocationID;
  const int y = int(gl_WorkGroupID.x);
  const int W = pc.width;
  const int k0 = int(lane) * K;
  const int row = y * W;
  uint window[K];  // census_right(x - d_min - k0 - k)
  [[unroll]] for (int k = 0; k < K; ++k) window[k] = census_right[row + column(clamp(-pc.min_disp - k0 - k, 0, W - 1))];
  const int g = pc.cost_slice * pc.height + y;
  const int chunk = g / pc.rows_per_chunk;
  const int row_base = (g - chunk * pc.rows_per_chunk) * pc.row_words + int(lane) * (K / 4);
  for (int x = 0; x < W; ++x) {
    if (x > 0) {
      const uint carried = subgroupShuffleUp(window[K - 1], 1u);
      [[unroll]] for (int k = K - 1; k > 0; --k) window[k] = window[k - 1];
      window[0] = lane == 0u ? census_right[row + column(clamp(x - pc.min_disp, 0, W - 1))] : carried;
    }
    const uint cl = census_left[row + column(x)];
    const int base = row_base + x * (K / 4) * int(gl_SubgroupSize);
    [[unroll]] for (int j = 0; j < K / 4; ++j) {
      uint word = 0u;
      [[unroll]] for (int b = 0; b < 4; ++b) {
        // Disparities beyond the range (padding to whole words) cost 255: they never win (see sgm_aggregate).
        const uint c = k0 + 4 * j + b < pc.num_disp ? uint(bitCount(cl ^ window[4 * j + b])) : 255u;
        word |= c << (8 * b);
      }
      volume[chunk].v[base + j] = word;
    }
  }
}
