#version 450
// Winner-takes-all after sgm_aggregate_rowpass.comp: S = forward sums + backward sums, the smallest disparity
// of least S (uniqueness test as OpenCV's uniquenessRatio, equiangular subpixel in integer arithmetic, 1/16 px),
// and the right image's disparity by the diagonal search min_k S(xr + d_min + k, y, k). The same results as
// sgm_wta.comp, in the lane layout of the row passes.
// One workgroup (= one subgroup) per row; lane l owns disparities l*K .. l*K+K-1. The diagonal search is a shift
// register along the row: slot j holds the best (S << 8 | d) so far for xr = x - d_min - j; after pixel x the slot
// D - 1 is complete. Results are gathered one pixel per lane and stored a subgroup at a time.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = 0) in;            // = subgroup size
const uint SG = gl_WorkGroupSize.x;
layout(constant_id = 4) const int LOG2_SG = 3;  // log2(SG): loops with a plain counter are unrolled
layout(constant_id = 1) const int K = 16;   // a multiple of 8
layout(constant_id = 2) const int D = 128;  // num_disparities
layout(push_constant) uniform Params {
  int width, height, min_disp, uniqueness;
  int subpixel;
} pc;
layout(binding = 0, rgba32ui) uniform readonly uimageBuffer sums;  // [pass][y][x][lane][K x 16 bits]
layout(std430, binding = 1) writeonly buffer DispLeft { int disp_left[]; };
layout(std430, binding = 2) writeonly buffer DispRight { int disp_right[]; };

const uint NONE = 0xFFFFFFFFu;
uint lane;

uint butterflyMin(uint v) {
  [[unroll]] for (int i = 0; i < LOG2_SG; ++i) v = min(v, subgroupShuffleXor(v, 1u << i));
  return v;
}
uint butterflyOr(uint v) {
  [[unroll]] for (int i = 0; i < LOG2_SG; ++i) v |= subgroupShuffleXor(v, 1u << i);
  return v;
}

// One result per lane: lane (x mod subgroup size) keeps the value of pixel x; a full group is stored at once.
struct Gather {
  int value;
};
void gatherPut(inout Gather g, int x, int v, int row_base, bool is_left) {
  const int slot = x & int(gl_SubgroupSize - 1u);
  g.value = int(lane) == slot ? v : g.value;
  if (slot == int(gl_SubgroupSize) - 1 || x == pc.width - 1) {
    const int first = x - slot;
    if (first + int(lane) <= x) {
      if (is_left) disp_left[row_base + first + int(lane)] = g.value;
      else disp_right[row_base + first + int(lane)] = g.value;
    }
    g.value = E3D_INVALID;
  }
}

void main() {
  lane = gl_SubgroupInvocationID;
  const int y = int(gl_WorkGroupID.x);
  const int W = pc.width, H = pc.height;
  const int SG = int(gl_SubgroupSize);
  const int k0 = int(lane) * K;
  const int row_base = y * W;
  // The slot that completes after each pixel: disparity D - 1.
  const int done_k = (D - 1) % K;
  const uint done_lane = uint((D - 1) / K);
  uint shift[K];
  [[unroll]] for (int k = 0; k < K; ++k) shift[k] = NONE;
  Gather left = Gather(E3D_INVALID), right = Gather(E3D_INVALID);
  // t: the pixel whose costs enter the shift register; it runs on until every xr in [0, W) has left slot D - 1.
  const int t_first = min(0, pc.min_disp + D - 1);
  const int t_last = max(W - 1, W - 1 + pc.min_disp + D - 1);
  for (int t = t_first; t <= t_last; ++t) {
    const uint carried = subgroupShuffleUp(shift[K - 1], 1u);
    [[unroll]] for (int k = K - 1; k > 0; --k) shift[k] = shift[k - 1];
    shift[0] = lane == 0u ? NONE : carried;
    if (t >= 0 && t < W) {
      const int x = t;
      uint s[K];
      const int forward = ((y * W + x) * SG + int(lane)) * (K / 8);
      const int backward = (((H + y) * W + x) * SG + int(lane)) * (K / 8);
      [[unroll]] for (int q = 0; q < K / 8; ++q) {
        // each half word holds a sum of at most 4 x 255: adding the packed words cannot carry across halves
        const uvec4 w = imageLoad(sums, forward + q) + imageLoad(sums, backward + q);
        [[unroll]] for (int b = 0; b < 4; ++b) {
          s[8 * q + 2 * b] = w[b] & 0xFFFFu;
          s[8 * q + 2 * b + 1] = w[b] >> 16;
        }
      }
      uint local_key = NONE;
      [[unroll]] for (int k = 0; k < K; ++k) {
        const uint key = (s[k] << 8) | uint(k0 + k);
        if (k0 + k < D) {
          local_key = min(local_key, key);
          shift[k] = min(shift[k], key);
        }
      }
      const uint key = butterflyMin(local_key);
      const int best = int(key & 0xFFu);
      const uint best_cost = key >> 8;
      uint local_second = NONE, local_neighbours = 0u;
      [[unroll]] for (int k = 0; k < K; ++k) {
        const int d = k0 + k;
        if (d < D && abs(d - best) > 1) local_second = min(local_second, s[k]);
        if (d < D && d == best - 1) local_neighbours |= s[k] << 16;
        if (d < D && d == best + 1) local_neighbours |= s[k];
      }
      const uint second = butterflyMin(local_second);
      const uint neighbours = butterflyOr(local_neighbours);
      const int c0 = int(neighbours >> 16), c2 = int(neighbours & 0xFFFFu), c1 = int(best_cost);
      const bool valid =
          !(pc.uniqueness > 0 && second != NONE && second * uint(100 - pc.uniqueness) < best_cost * 100u);
      int d16 = (pc.min_disp + best) * 16;
      if (pc.subpixel != 0 && best > 0 && best + 1 < D) {
        const int den = max(c0, c2) - c1;
        if (den > 0) {
          const int num = 8 * (c0 - c2);
          const int mag = (2 * abs(num) + den) / (2 * den);
          d16 += num < 0 ? -mag : mag;
        }
      }
      gatherPut(left, x, valid ? d16 : E3D_INVALID, row_base, true);
    }
    const int xr = t - pc.min_disp - (D - 1);
    if (xr >= 0 && xr < W) {
      const uint done = subgroupShuffle(shift[done_k], done_lane);
      gatherPut(right, xr, done == NONE ? E3D_INVALID : (pc.min_disp + int(done & 0xFFu)) * 16, row_base, false);
    }
  }
}
