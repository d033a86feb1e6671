#version 450
// Winner-takes-all after sgm_aggregate_rowpass.comp: S = forward sums + backward sums, the smallest disparity
// of least S (uniqueness test as OpenCV's uniquenessRatio, equiangular subpixel in integer arithmetic, 1/16 px),
// and the right image's disparity by the diagonal search min_d S(xr + d_min + d, y, d). The same results as
// sgm_wta.comp, in the lane layout of the row passes.
// One workgroup (= one subgroup) per row; lane l owns disparities l*K .. l*K+K-1. The diagonal search is a shift
// register along the row: slot d holds the best (S << 8 | d) so far for xr = x - d_min - d; after pixel x the
// slot D - 1 is complete, after the row all are.
// The row is walked in groups of SG pixels, unrolled: lane u keeps the result of the u-th pixel of a group and the
// group is stored at once, at a fixed place in the unrolled body (lavapipe runs both sides of an if, so a
// conditional store costs as much as a store).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = 0) in;  // = subgroup size
const int SG = int(gl_WorkGroupSize.x);
layout(constant_id = 1) const int K = 16;        // a multiple of 8
layout(constant_id = 2) const int D = 128;       // num_disparities
layout(constant_id = 4) const int LOG2_SG = 3;   // log2(SG): loops with a plain counter are unrolled
layout(constant_id = 6) const int MIN_DISP = 0;  // min_disparity
layout(push_constant) uniform Params {
  int width, height, uniqueness, subpixel;
} pc;
layout(binding = 0, rgba32ui) uniform readonly uimageBuffer sums;  // [pass][y][x][lane][K x 16 bits]
layout(std430, binding = 1) writeonly buffer DispLeft { int disp_left[]; };
layout(std430, binding = 2) writeonly buffer DispRight { int disp_right[]; };

const uint NONE = 0xFFFFFFFFu;
// The group position after which the right-image group of xr = x - MIN_DISP - (D - 1) is full.
const int RIGHT_FLUSH = ((SG - 1 + MIN_DISP + D - 1) % SG + SG) % SG;
uint lane;

uint butterflyMin(uint v) {
  [[unroll]] for (int i = 0; i < LOG2_SG; ++i) v = min(v, subgroupShuffleXor(v, 1u << i));
  return v;
}
uint butterflyOr(uint v) {
  [[unroll]] for (int i = 0; i < LOG2_SG; ++i) v |= subgroupShuffleXor(v, 1u << i);
  return v;
}
int rightDisparity(uint key) { return key == NONE ? E3D_INVALID : (MIN_DISP + int(key & 0xFFu)) * 16; }

void main() {
  lane = gl_SubgroupInvocationID;
  const int y = int(gl_WorkGroupID.x);
  const int W = pc.width, H = pc.height;
  const int k0 = int(lane) * K;
  const int row = y * W;
  // Right-image pixels that no left pixel reaches: [0, -d_min - D + 1) and (W - 1 - d_min, W - 1].
  for (int xr = int(lane); xr < min(W, -MIN_DISP - D + 1); xr += SG) disp_right[row + xr] = E3D_INVALID;
  for (int xr = max(0, W - MIN_DISP) + int(lane); xr < W; xr += SG) disp_right[row + xr] = E3D_INVALID;

  uint shift[K];
  [[unroll]] for (int k = 0; k < K; ++k) shift[k] = NONE;
  int left = E3D_INVALID, right = E3D_INVALID;
  int x_group = 0;
  for (; x_group < W; x_group += SG) {
    [[unroll]] for (int u = 0; u < SG; ++u) {
      const int x = x_group + u;
      const bool inside = x < W;  // the last group may reach beyond the row: those pixels add nothing
      const int xc = min(x, W - 1);
      uint s[K];
      const int forward = ((y * W + xc) * SG + int(lane)) * (K / 8);
      const int backward = (((H + y) * W + xc) * SG + int(lane)) * (K / 8);
      [[unroll]] for (int q = 0; q < K / 8; ++q) {
        // each half word holds a sum of at most 4 x 255: adding the packed words cannot carry across halves
        const uvec4 w = imageLoad(sums, forward + q) + imageLoad(sums, backward + q);
        [[unroll]] for (int b = 0; b < 4; ++b) {
          s[8 * q + 2 * b] = w[b] & 0xFFFFu;
          s[8 * q + 2 * b + 1] = w[b] >> 16;
        }
      }
      // Left image.
      uint local_key = NONE;
      [[unroll]] for (int k = 0; k < K; ++k)
        if (k0 + k < D) local_key = min(local_key, (s[k] << 8) | uint(k0 + k));
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
      int d16 = (MIN_DISP + best) * 16;
      const int den = max(c0, c2) - c1;
      if (pc.subpixel != 0 && best > 0 && best + 1 < D && den > 0) {
        const int num = 8 * (c0 - c2);
        const int mag = (2 * abs(num) + den) / (2 * den);
        d16 += num < 0 ? -mag : mag;
      }
      left = int(lane) == u ? (valid ? d16 : E3D_INVALID) : left;

      // Right image: the slots move up by one disparity, this pixel's costs enter, slot D - 1 is complete.
      const uint carried = subgroupShuffleUp(shift[K - 1], 1u);
      [[unroll]] for (int k = K - 1; k > 0; --k) shift[k] = shift[k - 1];
      shift[0] = lane == 0u ? NONE : carried;
      [[unroll]] for (int k = 0; k < K; ++k)
        if (k0 + k < D && inside) shift[k] = min(shift[k], (s[k] << 8) | uint(k0 + k));
      const uint done = subgroupShuffle(shift[(D - 1) % K], uint((D - 1) / K));
      const int xr = x - MIN_DISP - (D - 1);
      right = int(lane) == (xr & (SG - 1)) ? rightDisparity(done) : right;
      if (u == RIGHT_FLUSH) {  // a constant: only this copy of the body stores
        const int xr_lane = xr - (SG - 1) + int(lane);
        if (xr_lane >= 0 && xr_lane < W) disp_right[row + xr_lane] = right;
      }
    }
    if (x_group + int(lane) < W) disp_left[row + x_group + int(lane)] = left;
  }
  // The last group of right-image pixels emitted in the loop, if it was not stored, and the slots d < D - 1
  // (complete: no pixel of the row is left to contribute).
  const int x_last = x_group - 1;
  const int xr_last = x_last - MIN_DISP - (D - 1);
  const int stored_end = xr_last - ((xr_last - (SG - 1)) % SG + SG) % SG;  // last xr = SG - 1 (mod SG) up to xr_last
  const int xr_lane = stored_end + 1 + int(lane);
  if (xr_lane <= xr_last && xr_lane >= 0 && xr_lane < W) disp_right[row + xr_lane] = right;
  [[unroll]] for (int k = 0; k < K; ++k) {
    const int d = k0 + k;
    const int xr = x_last - MIN_DISP - d;
    if (d < D - 1 && xr >= 0 && xr < W) disp_right[row + xr] = rightDisparity(shift[k]);
  }
}
