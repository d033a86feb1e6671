#version 450
// 3x3 median of both disparity maps (border clamped; invalid pixels take part with their value).
// z = 0 left map, z = 1 right map.
layout(local_size_x = 16, local_size_y = 8) in;
layout(push_constant) uniform Params { int width; int height; } pc;
layout(std430, binding = 0) readonly buffer InLeft { int in_left[]; };
layout(std430, binding = 1) readonly buffer InRight { int in_right[]; };
layout(std430, binding = 2) writeonly buffer OutLeft { int out_left[]; };
layout(std430, binding = 3) writeonly buffer OutRight { int out_right[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= pc.width || y >= pc.height) return;
  const bool right = gl_GlobalInvocationID.z == 1u;
  int v[9];
  int n = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int idx = clamp(y + dy, 0, pc.height - 1) * pc.width + clamp(x + dx, 0, pc.width - 1);
      v[n++] = right ? in_right[idx] : in_left[idx];
    }
  // Partial selection sort: the 5th smallest is the median.
  for (int i = 0; i < 5; ++i)
    for (int j = i + 1; j < 9; ++j) {
      const int a = v[i], b = v[j];
      v[i] = min(a, b);
      v[j] = max(a, b);
    }
  if (right) out_right[y * pc.width + x] = v[4];
  else out_left[y * pc.width + x] = v[4];
}
