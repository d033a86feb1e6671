// Shared by the cost stages of the intensity costs (cost_ad, cost_sad, cost_mi): the push constants, the images,
// and the cost volume they write. Included after the specialisation constants K and MIRROR.
// The volume: rows g = base_row + y of row_words 32-bit words, split over buffers of rows_per_chunk rows; in a row,
// pixel x holds the SG lanes' K bytes, lane l's at byte (x * SG + l) * K (the lane layout of the aggregation:
// lane l owns disparities l*K .. l*K+K-1). Disparities beyond the range (padding to whole lanes) cost 255: their
// path costs stay >= 255 and never win against real ones.
#ifndef COST_VOLUME_GLSL
#define COST_VOLUME_GLSL
#define E3D_COST_VOLUME_PARAMS
#include "ips/e3d_shaders/match_stages.h"
// The 8-bit images, four pixels to a word, read as texels; bound swapped for MIRROR (the second match, which reads
// them mirrored: the mirrored right image is the left one).
layout(binding = 0, r32ui) uniform readonly uimageBuffer image_left;
layout(binding = 1, r32ui) uniform readonly uimageBuffer image_right;
layout(std430, binding = 4) writeonly buffer Volume32 { uint v[]; } volume32[E3D_MAX_CHUNKS];
layout(std430, binding = 4) writeonly buffer Volume64 { uint64_t v[]; } volume64[E3D_MAX_CHUNKS];

uint grey(bool right, int y, int x) {
  x = clamp(x, 0, pc.width - 1);
  const int idx = clamp(y, 0, pc.height - 1) * pc.width + (MIRROR ? pc.width - 1 - x : x);
  const uint word = right ? imageLoad(image_right, idx >> 2).x : imageLoad(image_left, idx >> 2).x;
  return (word >> ((idx & 3) << 3)) & 0xFFu;
}

// Stores this lane's K costs of pixel x of row y (64-bit components when K allows: lavapipe stores a vector
// component by component in a loop over the lanes).
void storeCosts(int y, int x, uint c[K]) {
  const int g = pc.base_row + y;
  const int chunk = g / pc.rows_per_chunk;
  const int word = (g - chunk * pc.rows_per_chunk) * pc.row_words + (x * int(gl_SubgroupSize) + int(gl_SubgroupInvocationID)) * (K / 4);
  uint words[K / 4];
  [[unroll]] for (int j = 0; j < K / 4; ++j)
    words[j] = min(c[4 * j], 255u) | (min(c[4 * j + 1], 255u) << 8) | (min(c[4 * j + 2], 255u) << 16) |
               (min(c[4 * j + 3], 255u) << 24);
  if (K % 8 == 0) {
    [[unroll]] for (int j = 0; j < K / 8; ++j)
      volume64[chunk].v[word / 2 + j] = packUint2x32(uvec2(words[2 * j], words[2 * j + 1]));
  } else {
    [[unroll]] for (int j = 0; j < K / 4; ++j) volume32[chunk].v[word + j] = words[j];
  }
}
#endif
