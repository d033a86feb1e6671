#version 450
// 3x3 median of both disparity maps (border clamped; invalid pixels take part with their value).
// Each invocation computes a column of STRIP pixels, sliding the 3x3 window down (3 new values per output).
// z = 0 left map, z = 1 right map.
#extension GL_EXT_control_flow_attributes : require
#extension GL_GOOGLE_include_directive : require
#include "ips/e3d_shaders/interface.h"
layout(local_size_x = E3D_GROUP_SIZE) in;
const int STRIP = E3D_STRIP;
#define E3D_IMAGE_PARAMS
#include "ips/e3d_shaders/image_stages.h"
layout(binding = 0, r32i) uniform readonly iimageBuffer in_left;
layout(binding = 1, r32i) uniform readonly iimageBuffer in_right;
layout(std430, binding = 2) writeonly buffer OutLeft { int out_left[]; };
layout(std430, binding = 3) writeonly buffer OutRight { int out_right[]; };

int valueAt(bool right, int x, int y) {
  const int idx = clamp(y, 0, pc.height - 1) * pc.width + clamp(x, 0, pc.width - 1);
  return right ? imageLoad(in_right, idx).x : imageLoad(in_left, idx).x;
}

void sort2(inout int a, inout int b) {
  const int lo = min(a, b);
  b = max(a, b);
  a = lo;
}

// Median of 9 with the classic 19-exchange network (Paeth).
int median9(int v[9]) {
  sort2(v[1], v[2]); sort2(v[4], v[5]); sort2(v[7], v[8]);
  sort2(v[0], v[1]); sort2(v[3], v[4]); sort2(v[6], v[7]);
  sort2(v[1], v[2]); sort2(v[4], v[5]); sort2(v[7], v[8]);
  sort2(v[0], v[3]); sort2(v[5], v[8]); sort2(v[4], v[7]);
  sort2(v[3], v[6]); sort2(v[1], v[4]); sort2(v[2], v[5]);
  sort2(v[4], v[7]); sort2(v[4], v[2]); sort2(v[6], v[4]);
  sort2(v[4], v[2]);
  return v[4];
}

void main() {
  const int x = int(gl_GlobalInvocationID.x);
  const int y0 = int(gl_GlobalInvocationID.y) * STRIP;
  if (x >= pc.width || y0 >= pc.height) return;
  const bool right = gl_GlobalInvocationID.z == 1u;
  int window[3][3];  // [row][column], rows y - 1 .. y + 1
  [[unroll]] for (int r = 0; r < 2; ++r)
    [[unroll]] for (int c = 0; c < 3; ++c) window[r + 1][c] = valueAt(right, x + c - 1, y0 + r - 1);
  [[unroll]] for (int i = 0; i < STRIP; ++i) {
    [[unroll]] for (int r = 0; r < 2; ++r)
      [[unroll]] for (int c = 0; c < 3; ++c) window[r][c] = window[r + 1][c];
    [[unroll]] for (int c = 0; c < 3; ++c) window[2][c] = valueAt(right, x + c - 1, y0 + i + 1);
    int v[9];
    [[unroll]] for (int r = 0; r < 3; ++r)
      [[unroll]] for (int c = 0; c < 3; ++c) v[3 * r + c] = window[r][c];
    const int m = median9(v);
    const int y = y0 + i;
    if (y < pc.height) {
      if (right) out_right[y * pc.width + x] = m;
      else out_left[y * pc.width + x] = m;
    }
  }
}
