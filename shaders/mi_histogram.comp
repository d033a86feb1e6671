#version 450
// The joint histogram of Mutual Information (ips/e3d/matching_cost.hpp, step 1): for every pixel with a valid
// disparity whose match is inside the row, count (L(p), R(p - d)). The disparity is, by `mode`: 0 the start of the
// hierarchy (pseudo-random, miStartHash), 1 a map of this level, 2 the map of the level below, doubled (each pixel
// from (x / 2, y / 2)). Bin 65536 counts the pixels. One histogram per region of the region_columns x region_rows grid
// (E3D_MI_HISTOGRAM_ENTRIES each), the left pixel's region. One invocation per pixel.
#extension GL_GOOGLE_include_directive : require
#include "e3d_common.glsl"
layout(local_size_x = E3D_GROUP_SIZE) in;
#define E3D_MI_HISTOGRAM_PARAMS
#include "ips/e3d_shaders/match_stages.h"
layout(binding = 0, r32ui) uniform readonly uimageBuffer image_left;
layout(binding = 1, r32ui) uniform readonly uimageBuffer image_right;
layout(std430, binding = 2) readonly buffer Guide { int guide[]; };
layout(std430, binding = 3) buffer Histogram { uint histogram[]; };

uint grey(bool right, int idx) {
  const uint word = right ? imageLoad(image_right, idx >> 2).x : imageLoad(image_left, idx >> 2).x;
  return (word >> ((idx & 3) << 3)) & 0xFFu;
}

uint startHash(int x, int y) {  // as ips::e3d::miStartHash
  uint h = uint(x) * 0x9E3779B1u ^ uint(y) * 0x85EBCA77u;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  return h;
}

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= pc.width || y >= pc.height) return;
  int d16;
  if (pc.mode == 0) {
    d16 = (pc.min_disp + int(startHash(x, y) % uint(pc.num_disp))) * 16;
  } else if (pc.mode == 1) {
    d16 = guide[y * pc.width + x];
  } else {
    const int g = guide[min(y / 2, pc.guide_height - 1) * pc.guide_width + min(x / 2, pc.guide_width - 1)];
    d16 = g == E3D_INVALID ? E3D_INVALID : 2 * g;
  }
  if (d16 == E3D_INVALID) return;
  const int xr = x - ((d16 + 8) >> 4);
  if (xr < 0 || xr >= pc.width) return;
  const uint i = grey(false, y * pc.width + x), k = grey(true, y * pc.width + xr);
  const int region = E3D_REGION_OF(y, pc.region_rows, pc.height) * pc.region_columns +
                     E3D_REGION_OF(x, pc.region_columns, pc.width);
  const int base = region * E3D_MI_HISTOGRAM_ENTRIES;
  atomicAdd(histogram[base + int((i << 8) | k)], 1u);
  atomicAdd(histogram[base + 65536], 1u);
}
