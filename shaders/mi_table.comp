#version 450
// The Mutual Information cost table from the joint histogram (ips/e3d/matching_cost.hpp, steps 2-5), in the same
// integer arithmetic as ips::e3d::miTable, so the two agree bit for bit. One workgroup of 256 invocations;
// invocation c works on row c or column c of the 256 x 256 tables, with barriers between the steps. The separable
// smoothings run columns first where that lets each invocation write whole rows (they commute).
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require
#include "ips/e3d_shaders/interface.h"
layout(local_size_x = E3D_MI_TABLE_GROUP) in;
layout(std430, binding = 0) readonly buffer Histogram { uint histogram[]; };  // 65536 bins + the count
layout(std430, binding = 1) readonly buffer Log2Fraction { int log2_fraction[]; };  // 256 entries
layout(std430, binding = 2) buffer Work64 { uint64_t work64[]; };  // 65536
layout(std430, binding = 3) buffer Work32 { int work32[]; };       // 2 x 65536
layout(std430, binding = 4) writeonly buffer Table { uint table[]; };  // 65536 bytes
shared uint64_t marginal_left[256], marginal_right[256];
shared int info_left[256], info_right[256];

const int PARZEN[7] = int[7](1, 6, 15, 20, 15, 6, 1);  // binomial, sum 64

int log2q8(uint64_t v) {  // 256 floor(log2 v) + the table's fraction of the 8 bits after the leading one
  const uint hi = uint(v >> 32), lo = uint(v);
  const int e = hi != 0u ? 32 + findMSB(hi) : findMSB(lo);
  const uint64_t top = e >= 8 ? v >> uint(e - 8) : v << uint(8 - e);
  return 256 * e + log2_fraction[int(top) - 256];
}

void sync() {
  memoryBarrierBuffer();
  memoryBarrierShared();
  barrier();
}

void main() {
  const int c = int(gl_LocalInvocationID.x);
  const uint64_t n = max(uint64_t(histogram[65536]), uint64_t(1));
  // 2. Smoothing of the histogram, zero outside (columns: invocation c, column c), and the marginals.
  uint64_t column_sum = 0;
  for (int i = 0; i < 256; ++i) {
    uint64_t acc = 0;
    [[unroll]] for (int t = 0; t < 7; ++t) {
      const int ii = i + t - 3;
      if (ii >= 0 && ii < 256) acc += uint64_t(PARZEN[t]) * histogram[ii * 256 + c];
    }
    work64[i * 256 + c] = acc;
    column_sum += histogram[i * 256 + c];
  }
  uint64_t row_sum = 0;
  for (int k = 0; k < 256; ++k) row_sum += histogram[c * 256 + k];
  marginal_left[c] = row_sum;
  marginal_right[c] = column_sum;
  sync();
  // Rows (invocation c, row c), then 3. the information of the joint histogram; the marginals likewise.
  for (int k = 0; k < 256; ++k) {
    uint64_t acc = 0;
    [[unroll]] for (int t = 0; t < 7; ++t) {
      const int kk = k + t - 3;
      if (kk >= 0 && kk < 256) acc += uint64_t(PARZEN[t]) * work64[c * 256 + kk];
    }
    work32[c * 256 + k] = log2q8(4096 * n) - log2q8(max(acc, uint64_t(1)));
  }
  uint64_t smooth_left = 0, smooth_right = 0;
  [[unroll]] for (int t = 0; t < 7; ++t) {
    const int ii = c + t - 3;
    if (ii >= 0 && ii < 256) {
      smooth_left += uint64_t(PARZEN[t]) * marginal_left[ii];
      smooth_right += uint64_t(PARZEN[t]) * marginal_right[ii];
    }
  }
  info_left[c] = log2q8(64 * n) - log2q8(max(smooth_left, uint64_t(1)));
  info_right[c] = log2q8(64 * n) - log2q8(max(smooth_right, uint64_t(1)));
  sync();
  // 4. Smoothing of the information, edges repeated: columns (invocation c) ...
  for (int i = 0; i < 256; ++i) {
    int acc = 0;
    [[unroll]] for (int t = 0; t < 7; ++t) acc += PARZEN[t] * work32[clamp(i + t - 3, 0, 255) * 256 + c];
    work32[65536 + i * 256 + c] = acc;
  }
  int entropy_left = 0, entropy_right = 0;
  [[unroll]] for (int t = 0; t < 7; ++t) {
    entropy_left += PARZEN[t] * info_left[clamp(c + t - 3, 0, 255)];
    entropy_right += PARZEN[t] * info_right[clamp(c + t - 3, 0, 255)];
  }
  sync();
  info_left[c] = entropy_left;  // now the smoothed entropies (scale 64)
  info_right[c] = entropy_right;
  sync();
  // ... then rows (invocation c, row c) and 5. the costs: mi x 4096 = 64 l + 64 r - j, cost = clamp(32 - round(4 mi)).
  for (int w = 0; w < 64; ++w) {
    uint packed = 0u;
    [[unroll]] for (int b = 0; b < 4; ++b) {
      const int k = 4 * w + b;
      int joint = 0;
      [[unroll]] for (int t = 0; t < 7; ++t) joint += PARZEN[t] * work32[65536 + c * 256 + clamp(k + t - 3, 0, 255)];
      const int64_t mi = 64 * int64_t(info_left[c]) + 64 * int64_t(info_right[k]) - int64_t(joint);
      const int quarter_bits = int((mi + (int64_t(1) << 17)) >> 18);
      packed |= uint(clamp(32 - quarter_bits, 0, 63)) << (8 * b);
    }
    table[c * 64 + w] = packed;
  }
}
