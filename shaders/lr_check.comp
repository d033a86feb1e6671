#version 450
// Left-right consistency check: a left disparity d survives when the right map at x - round(d) agrees
// within max_diff (1/16 px units). Output: the final left disparity map.
#extension GL_GOOGLE_include_directive : require
#include "e3d_common.glsl"
layout(local_size_x = E3D_LR_GROUP_X, local_size_y = E3D_LR_GROUP_Y) in;
#define E3D_LR_CHECK_PARAMS
#include "ips/e3d_shaders/image_stages.h"
layout(std430, binding = 0) readonly buffer Left { int left_disp[]; };
layout(std430, binding = 1) readonly buffer Right { int right_disp[]; };
layout(std430, binding = 2) writeonly buffer Out { int out_disp[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= pc.width || y >= pc.height) return;
  int d = left_disp[y * pc.width + x];
  if (d != E3D_INVALID) {
    const int xr = x - ((d + 8) >> 4);
    if (xr < 0 || xr >= pc.width) {
      d = E3D_INVALID;
    } else {
      const int r = right_disp[y * pc.width + xr];
      if (r == E3D_INVALID || abs(d - r) > pc.max_diff16) d = E3D_INVALID;
    }
  }
  out_disp[y * pc.width + x] = d;
}
