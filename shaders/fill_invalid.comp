#version 450
// Optional filling of pixels without a disparity (occluded or inconsistent), after Hirschmueller 2008: each
// invalid pixel takes the smaller (farther, background) of the nearest valid disparities to its left and
// right on the same row; rows without any valid pixel stay invalid. One invocation per row.
#extension GL_GOOGLE_include_directive : require
#include "e3d_common.glsl"
layout(local_size_x = E3D_GROUP_SIZE) in;
#define E3D_IMAGE_PARAMS
#include "ips/e3d_shaders/image_stages.h"
layout(std430, binding = 0) readonly buffer In { int in_disp[]; };
layout(std430, binding = 1) buffer Out { int out_disp[]; };

void main() {
  const int y = int(gl_GlobalInvocationID.x);
  if (y >= pc.height) return;
  const int row = y * pc.width;
  int next_valid = E3D_INVALID;  // nearest valid to the right
  for (int x = pc.width - 1; x >= 0; --x) {
    const int d = in_disp[row + x];
    if (d != E3D_INVALID) next_valid = d;
    out_disp[row + x] = next_valid;
  }
  int last_valid = E3D_INVALID;  // nearest valid to the left
  for (int x = 0; x < pc.width; ++x) {
    const int d = in_disp[row + x];
    if (d != E3D_INVALID) {
      last_valid = d;
    } else if (last_valid != E3D_INVALID) {
      const int right = out_disp[row + x];
      out_disp[row + x] = right == E3D_INVALID ? last_valid : min(last_valid, right);
    }
  }
}
