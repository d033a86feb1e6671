#version 450
// The Mutual Information cost table from the joint histogram (ips/e3d/matching_cost.hpp, steps 2-5), in the same
// integer arithmetic as ips::e3d::miTable, so the two agree bit for bit. Four dispatches (STEP 0..3), each of 256
// invocations in E3D_MI_TABLE_GROUP-sized workgroups: invocation c works on column c or row c of the 256 x 256
// tables. The separable smoothings run columns first where that lets each invocation write whole rows (they
// commute); each walks its column or row with the kernel's seven inputs in registers, one load per output (a load
// at a per-invocation index is a loop over the lanes on lavapipe: seven per output cost three times the time).
// Why four dispatches rather than one workgroup with barriers: lavapipe runs a workgroup on one thread,
// so a single workgroup of 256 leaves the other cores idle; between dispatches the buffers carry the steps' results.
//   STEP 0: columns of the histogram smoothed (work64), the right marginal (column sums)
//   STEP 1: rows smoothed and the joint information (work32 [0, 65536)), the marginals' information (the left
//           marginal smoothed: the row sums of step 0's columns)
//   STEP 2: columns of the information smoothed (work32 [65536, 131072)), the marginals' information smoothed
//   STEP 3: rows of the information smoothed and the costs
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require
#include "ips/e3d_shaders/interface.h"
layout(local_size_x = E3D_MI_TABLE_GROUP) in;
layout(constant_id = E3D_SPEC_MI_TABLE_STEP) const int STEP = 0;
layout(std430, binding = 0) readonly buffer Histogram { uint histogram[]; };  // per region: 65536 bins + the count
// 256 entries (a uniform buffer: lavapipe gathers from it without a loop over the lanes).
layout(std140, binding = 1) uniform Log2Fraction { ivec4 log2_fraction[64]; };
// E3D_MI_WORK64_ENTRIES: the smoothed histogram, then the right marginal (256).
layout(std430, binding = 2) buffer Work64 { uint64_t work64[]; };
// E3D_MI_WORK32_ENTRIES: the information, its column-smoothed copy, then the left and right marginals' information
// and their smoothed values (256 each).
layout(std430, binding = 3) buffer Work32 { int work32[]; };
layout(std430, binding = 4) writeonly buffer Table { uint table[]; };  // per region: 65536 bytes

const int PARZEN[7] = int[7](1, 6, 15, 20, 15, 6, 1);  // binomial, sum 64
const int MARGINAL_RIGHT = 65536;                                 // in work64
const int SMOOTHED_INFO = 65536;                                  // in work32
const int INFO_LEFT = 2 * 65536, INFO_RIGHT = INFO_LEFT + 256;    // in work32
const int ENTROPY_LEFT = INFO_LEFT + 512, ENTROPY_RIGHT = INFO_LEFT + 768;

int log2q8(uint64_t v) {  // 256 floor(log2 v) + the table's fraction of the 8 bits after the leading one
  const uint hi = uint(v >> 32), lo = uint(v);
  const int e = hi != 0u ? 32 + findMSB(hi) : findMSB(lo);
  const uint64_t top = e >= 8 ? v >> uint(e - 8) : v << uint(8 - e);
  const int j = int(top) - 256;
  return 256 * e + log2_fraction[j >> 2][j & 3];
}

// The seven inputs of the kernel about position p of a walk, p - 3 .. p + 3 (64-bit: the histogram's steps).
uint64_t window64[7];
int window32[7];
void slide64(uint64_t next) {
  [[unroll]] for (int t = 0; t < 6; ++t) window64[t] = window64[t + 1];
  window64[6] = next;
}
void slide32(int next) {
  [[unroll]] for (int t = 0; t < 6; ++t) window32[t] = window32[t + 1];
  window32[6] = next;
}
uint64_t smoothed64() {
  uint64_t acc = 0;
  [[unroll]] for (int t = 0; t < 7; ++t) acc += uint64_t(PARZEN[t]) * window64[t];
  return acc;
}
int smoothed32() {
  int acc = 0;
  [[unroll]] for (int t = 0; t < 7; ++t) acc += PARZEN[t] * window32[t];
  return acc;
}

void main() {
  const int c = int(gl_GlobalInvocationID.x);
  // Region gl_WorkGroupID.y: its histogram, work entries and table.
  const int region = int(gl_WorkGroupID.y);
  const int hb = region * E3D_MI_HISTOGRAM_ENTRIES, w64 = region * E3D_MI_WORK64_ENTRIES;
  const int w32 = region * E3D_MI_WORK32_ENTRIES, tb = region * (E3D_MI_TABLE_BYTES / 4);
  const uint64_t n = max(uint64_t(histogram[hb + 65536]), uint64_t(1));
  if (STEP == 0) {
    // 2. Smoothing of the histogram, zero outside: column c; the right marginal (column sums). The left marginal's
    // smoothing is the sum of a row of the smoothed histogram (step 1).
    uint64_t column_sum = 0;
    [[unroll]] for (int t = 0; t < 7; ++t) window64[t] = t < 3 ? uint64_t(0) : uint64_t(histogram[hb + (t - 3) * 256 + c]);
    for (int i = 0; i < 256; ++i) {
      work64[w64 + i * 256 + c] = smoothed64();
      column_sum += window64[3];
      slide64(i + 4 < 256 ? uint64_t(histogram[hb + min(i + 4, 255) * 256 + c]) : uint64_t(0));
    }
    work64[w64 + MARGINAL_RIGHT + c] = column_sum;
  } else if (STEP == 1) {
    // Row c, then 3. the information of the joint histogram; the marginals likewise.
    const int log_joint_total = log2q8(4096 * n);
    // The smoothed left marginal of row c: sum_k of the column-smoothed histogram's row c (the smoothing along the
    // rows of the row sums).
    uint64_t smooth_left = 0, smooth_right = 0;
    [[unroll]] for (int t = 0; t < 7; ++t) window64[t] = t < 3 ? uint64_t(0) : work64[w64 + c * 256 + t - 3];
    for (int k = 0; k < 256; ++k) {
      work32[w32 + c * 256 + k] = log_joint_total - log2q8(max(smoothed64(), uint64_t(1)));
      smooth_left += window64[3];
      slide64(k + 4 < 256 ? work64[w64 + c * 256 + min(k + 4, 255)] : uint64_t(0));
    }
    [[unroll]] for (int t = 0; t < 7; ++t) {
      const int ii = c + t - 3;
      if (ii >= 0 && ii < 256) smooth_right += uint64_t(PARZEN[t]) * work64[w64 + MARGINAL_RIGHT + ii];
    }
    const int log_marginal_total = log2q8(64 * n);
    work32[w32 + INFO_LEFT + c] = log_marginal_total - log2q8(max(smooth_left, uint64_t(1)));
    work32[w32 + INFO_RIGHT + c] = log_marginal_total - log2q8(max(smooth_right, uint64_t(1)));
  } else if (STEP == 2) {
    // 4. Smoothing of the information, edges repeated: column c; the marginals' information (scale 64).
    [[unroll]] for (int t = 0; t < 7; ++t) window32[t] = work32[w32 + max(t - 3, 0) * 256 + c];
    for (int i = 0; i < 256; ++i) {
      work32[w32 + SMOOTHED_INFO + i * 256 + c] = smoothed32();
      slide32(work32[w32 + min(i + 4, 255) * 256 + c]);
    }
    int entropy_left = 0, entropy_right = 0;
    [[unroll]] for (int t = 0; t < 7; ++t) {
      entropy_left += PARZEN[t] * work32[w32 + INFO_LEFT + clamp(c + t - 3, 0, 255)];
      entropy_right += PARZEN[t] * work32[w32 + INFO_RIGHT + clamp(c + t - 3, 0, 255)];
    }
    work32[w32 + ENTROPY_LEFT + c] = entropy_left;
    work32[w32 + ENTROPY_RIGHT + c] = entropy_right;
  } else {
    // Row c, then 5. the costs: mi x 4096 = 64 l + 64 r - j, cost = clamp(32 - round(4 mi), 0, 63).
    const int64_t entropy_left = 64 * int64_t(work32[w32 + ENTROPY_LEFT + c]);
    const int row = w32 + SMOOTHED_INFO + c * 256;
    [[unroll]] for (int t = 0; t < 7; ++t) window32[t] = work32[row + max(t - 3, 0)];
    for (int w = 0; w < 64; ++w) {
      uint packed = 0u;
      [[unroll]] for (int b = 0; b < 4; ++b) {
        const int k = 4 * w + b;
        const int64_t mi = entropy_left + 64 * int64_t(work32[w32 + ENTROPY_RIGHT + k]) - int64_t(smoothed32());
        const int quarter_bits = int((mi + (int64_t(1) << 17)) >> 18);
        packed |= uint(clamp(32 - quarter_bits, 0, 63)) << (8 * b);
        slide32(work32[row + min(k + 4, 255)]);
      }
      table[tb + c * 64 + w] = packed;
    }
  }
}
