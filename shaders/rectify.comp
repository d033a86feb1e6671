#version 450
// Rectification of the raw pair on the device: for each rectified pixel, bilinear interpolation of the raw
// image at the position given by the maps of ips::StereoRectification (as cv::remap with INTER_LINEAR and a
// constant 0 border), times the flat-field gain of the sampled raw position (StereoRectification::gain0/1, all 1
// without vignetting). Each invocation writes one word = 4 pixels; z = 0 camera 0, z = 1 camera 1.
#extension GL_GOOGLE_include_directive : require
#include "e3d_common.glsl"
layout(local_size_x = E3D_GROUP_SIZE) in;
#define E3D_RECTIFY_PARAMS
#include "ips/e3d_shaders/image_stages.h"
layout(std430, binding = 0) readonly buffer Raw0 { uint raw0[]; };
layout(std430, binding = 1) readonly buffer Raw1 { uint raw1[]; };
layout(std430, binding = 2) readonly buffer Maps { float maps[]; };  // map0x, map0y, map1x, map1y, gain0, gain1
layout(std430, binding = 3) writeonly buffer Out0 { uint out0[]; };
layout(std430, binding = 4) writeonly buffer Out1 { uint out1[]; };

float rawAt(bool cam1, int x, int y) {
  if (x < 0 || y < 0 || x >= pc.raw_width || y >= pc.raw_height) return 0.0;
  const int idx = y * pc.raw_width + x;
  return float(cam1 ? E3D_PIXEL(raw1, idx) : E3D_PIXEL(raw0, idx));
}

void main() {
  const int word = int(gl_GlobalInvocationID.x);
  const int n = pc.width * pc.height;
  if (4 * word >= n) return;
  const bool cam1 = gl_GlobalInvocationID.z == 1u;
  const int map_x = cam1 ? 2 * n : 0, map_y = cam1 ? 3 * n : n, gain = cam1 ? 5 * n : 4 * n;
  uint packed = 0u;
  for (int i = 0; i < 4; ++i) {
    const int idx = 4 * word + i;
    if (idx >= n) break;
    const float sx = maps[map_x + idx], sy = maps[map_y + idx];
    const int x0 = int(floor(sx)), y0 = int(floor(sy));
    const float fx = sx - float(x0), fy = sy - float(y0);
    const float sampled = mix(mix(rawAt(cam1, x0, y0), rawAt(cam1, x0 + 1, y0), fx),
                              mix(rawAt(cam1, x0, y0 + 1), rawAt(cam1, x0 + 1, y0 + 1), fx), fy);
    // precise: the product rounded before the half is added, as rectifyPair does (no fused multiply-add).
    precise const float v = sampled * maps[gain + idx];
    // Half-way values up, as cv::remap rounds: GLSL leaves round() at .5 to the implementation (lavapipe rounds to
    // even), and the rectified images must not depend on the device.
    packed |= uint(clamp(floor(v + 0.5), 0.0, 255.0)) << (8 * i);
  }
  if (cam1) out1[word] = packed;
  else out0[word] = packed;
}
