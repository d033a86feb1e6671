#version 450
// SGM for CPU devices (lavapipe): path aggregation in two row passes with the winner-takes-all fused in.
// sgm_aggregate.comp + sgm_wta.comp are the layout for GPUs; both give the same maps (see ips/e3d/sgm.hpp).
//
// Workgroup 0 (the forward pass) walks the rows top to bottom and each row left to right: paths (1,0), (0,1),
// (1,1), (-1,1). Workgroup 1 (the backward pass) walks bottom to top, right to left: (-1,0), (0,-1), (-1,-1),
// (1,-1). With 4 paths each pass computes its first two. Each pass is one subgroup, working on G pixels at once (G
// rows, see G below), each on a group of LPP lanes; lane l of a group owns the disparities l*K .. l*K+K-1 (the libSGM
// layout), neighbours d+-1 across lanes come from shuffles.
//  - Census matching costs are computed on the fly: C = popcount(census_left(x) ^ census_right(x - d_min - d));
//    along a row the right census values slide by one disparity per pixel (one load and one shuffle per pixel).
//    The other costs (COST_VOLUME) are read from the cost volume their cost stage wrote (one texel per pixel).
//  - The horizontal path stays in registers. The three paths that come from the previous row read its path costs
//    from a scratch buffer (two rows per pass, one byte per disparity: L <= maxCost + P2 <= 255) and write the
//    current row's. Paths 0 and 1 of a lane lie side by side and are written by one store when they fit in 32
//    bytes (K <= 16): a store costs a loop over the lanes whatever its size (below); one store less per pixel
//    made the match about 10 % faster on lavapipe.
//  - The image is split at row `split`. In the first dispatches (PHASE 0) the forward pass walks the rows above
//    it and the backward pass the rows below it, each storing the sum of its paths (16 bits per disparity); then
//    (PHASE 1) each walks on into the other part, adds the sums stored there by the other pass and selects the
//    disparities at once: the smallest disparity of least S (uniqueness test as OpenCV's uniquenessRatio,
//    equiangular subpixel in integer arithmetic, 1/16 px) and the right image's disparity by the diagonal search
//    min_d S(xr + d_min + d, d), a shift register along the row. So half the sums are stored, the two passes run
//    on two threads all the time, and no separate winner-takes-all walks over the sums.
// Why: on lavapipe every memory access whose address differs per lane is a loop over the lanes (10-20 times an
// arithmetic instruction); both sides of every if run (so the phases are specialisation constants, and
// direction-dependent steps are selects); and an invocation ends after 65535 loop iterations in all (so the host
// splits each walk over several dispatches; the scratch carries the state from one to the next).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = E3D_SPEC_SUBGROUP_SIZE) in;            // = subgroup size
const uint SG = gl_WorkGroupSize.x;
layout(constant_id = E3D_SPEC_LOG2_SUBGROUP_SIZE) const int LOG2_SG = 3;  // log2(SG): loops with a plain counter are unrolled
layout(constant_id = E3D_SPEC_LANE_DISPARITIES) const int K = 16;  // disparities per lane, a multiple of 8
layout(constant_id = E3D_SPEC_NUM_DISPARITIES) const int D = 128; // num_disparities
layout(constant_id = E3D_SPEC_NUM_PATHS) const int NUM_PATHS = 8;
layout(constant_id = E3D_SPEC_MIN_DISPARITY) const int MIN_DISP = 0;  // min_disparity
layout(constant_id = E3D_SPEC_PHASE) const int PHASE = 0;     // 0: store the sums, 1: add the stored sums and select
// MIRROR: the second match, right to left, for SgmParams::right_map "match": the images (bound swapped) are read
// mirrored, so that the mirrored right image is the left one, and the left map is stored mirrored back, as the
// right image's map (binding 8 is then the right map). RIGHT_MAP: the diagonal search for the right map.
layout(constant_id = E3D_SPEC_MIRROR) const bool MIRROR = false;
layout(constant_id = E3D_SPEC_RIGHT_MAP) const bool RIGHT_MAP = true;
// COST_VOLUME: the matching costs (ad, sad, mi) come from the cost volume the cost stage wrote ([y][x][lane][K
// bytes], in walk coordinates), not from the census codes.
layout(constant_id = E3D_SPEC_COST_VOLUME) const bool COST_VOLUME = false;
// G: the pixels one subgroup works on at once, each on LPP = SG / G lanes (G = 1: all lanes one pixel). G rows are
// walked together, row i0 + g by lane group g, two columns behind group g - 1, so that the three pixels of row
// i0 + g - 1 it needs are done (their path costs reach it through the scratch rows). Why: on lavapipe most of a
// pixel's cost does not grow with its disparities (memory accesses with per-lane addresses are loops over all lanes
// whatever their size; 640x480, 8 paths: 32 disparities took 80 ms, 128 took 104); G pixels share that work.
layout(constant_id = E3D_SPEC_ROW_PIXELS) const int G = 1;
const uint LPP = SG / uint(G);
const int LOG2_G = G >= 64 ? 6 : (G >= 32 ? 5 : (G >= 16 ? 4 : (G >= 8 ? 3 : (G >= 4 ? 2 : (G >= 2 ? 1 : 0)))));
const int LOG2_LPP = LOG2_SG - LOG2_G;
// Walk rows begin .. end - 1 of each pass (x: forward, y: backward; walk row i is image row i forward,
// height - 1 - i backward).
#define E3D_ROW_PASS_PARAMS
#include "ips/e3d_shaders/match_stages.h"
layout(binding = 0, r8ui) uniform readonly uimageBuffer image_left;
layout(binding = 1, r32ui) uniform readonly uimageBuffer census_left;
layout(binding = 2, r32ui) uniform readonly uimageBuffer census_right;
// The scratch rows, read as texels (one access per lane for 8 or 16 bytes) and written as a storage buffer.
layout(binding = 3, rgba32ui) uniform readonly uimageBuffer scratch_read16;
layout(binding = 4, rg32ui) uniform readonly uimageBuffer scratch_read8;
// 64-bit components: lavapipe stores a vector in one loop over the lanes, each component checked and stored in it,
// so few and wide stores are the cheap ones.
layout(std430, binding = 5) writeonly buffer ScratchWrite16 { u64vec2 scratch_write16[]; };
layout(std430, binding = 5) writeonly buffer ScratchWrite8 { uint64_t scratch_write8[]; };
layout(std430, binding = 5) writeonly buffer ScratchWrite32 { u64vec4 scratch_write32[]; };
// The sums [y][x][lane][K x 16 bits] (rows above split: forward, from split on: backward), stored in ranges of
// at most maxStorageBufferRange rows and read as texels.
layout(std430, binding = 6) writeonly buffer Sums32 { u64vec4 v[]; } sums32[E3D_MAX_CHUNKS];
layout(std430, binding = 6) writeonly buffer Sums16 { uvec4 v[]; } sums16[E3D_MAX_CHUNKS];
layout(binding = 7, rgba32ui) uniform readonly uimageBuffer sums_read;
layout(std430, binding = 8) writeonly buffer DispLeft { int disp_left[]; };
layout(std430, binding = 9) writeonly buffer DispRight { int disp_right[]; };
layout(binding = 10, rgba32ui) uniform readonly uimageBuffer costs16;
layout(binding = 11, rg32ui) uniform readonly uimageBuffer costs8;

const bool WIDE = (K % 16) == 0;              // 16-byte scratch accesses, 32-byte sum stores (else 8 and 16)
const int ROW_DIRS = NUM_PATHS == 8 ? 3 : 1;  // paths that come from the previous row
const uint NONE = 0xFFFFFFFFu;
// Whether the lanes hold disparities beyond the range (padding to whole lanes); when not, the tests are constants.
const bool PADDED = D < int(LPP) * K;
bool real(int d) { return !PADDED || d < D; }

uint lane;  // within the lane group of this pixel (0 .. LPP - 1)
uint grp;   // the lane group (0 .. G - 1)

int column(int x) { return MIRROR ? pc.width - 1 - x : x; }  // image column of walk column x

uint butterflyMin(uint v) {
  [[unroll]] for (int i = 0; i < LOG2_LPP; ++i) v = min(v, subgroupShuffleXor(v, 1u << i));
  return v;
}

uint butterflyOr(uint v) {
  [[unroll]] for (int i = 0; i < LOG2_LPP; ++i) v |= subgroupShuffleXor(v, 1u << i);
  return v;
}

uint laneMinimum(uint v[K]) {
  uint m = v[0];
  [[unroll]] for (int k = 1; k < K; ++k) m = min(m, v[k]);
  return m;
}

// L(p) = C(p) + min(L(p-r, d), L(p-r, d+-1) + P1, min L(p-r) + P2') - min L(p-r)
void pathStep(uint prev[K], uint cost[K], uint prev_min, uint p2, out uint cur[K]) {
  uint below = subgroupShuffleUp(prev[K - 1], 1u);
  uint above = subgroupShuffleDown(prev[0], 1u);
  below = lane == 0u ? E3D_BIG : below;
  above = lane == LPP - 1u ? E3D_BIG : above;
  const uint jump = prev_min + p2;
  const uint P1 = uint(pc.p1);
  [[unroll]] for (int k = 0; k < K; ++k) {
    const uint lo = k == 0 ? below : prev[k - 1];
    const uint hi = k == K - 1 ? above : prev[k + 1];
    cur[k] = cost[k] + min(min(prev[k], jump), min(lo, hi) + P1) - prev_min;
  }
}

// P2' = max(P1, P2 - p2_slope * |dI| / 16)
uint adaptiveP2(uint a, uint b) {
  return uint(max(pc.p1, pc.p2 - (pc.p2_slope * abs(int(a) - int(b))) / 16));
}

// Index of this lane's first 8-byte word of path dir in the scratch row (pass, half) at column x. Layout: paths 0 and
// 1 as [pass][half][x][lane][path 0, path 1][K bytes], then path 2 as [pass][half][x][lane][K bytes].
int scratchIndex(int pass, int half_row, int dir, int x) {
  const int lane_row = ((pass * 2 + half_row) * pc.width + x) * int(LPP) + int(lane);
  const int pair_words = 4 * pc.width * int(LPP) * 2 * (K / 8);
  return dir < 2 ? (lane_row * 2 + dir) * (K / 8) : pair_words + lane_row * (K / 8);
}

// This lane's K bytes at 8-byte word index8 of the scratch rows or (from_costs) of the cost volume: one texel load
// per 16 (or 8) bytes. from_costs is a constant at every call, so only one of the images is read.
void loadLaneBytes(bool from_costs, int index8, out uint v[K]) {
  if (WIDE) {
    [[unroll]] for (int q = 0; q < K / 16; ++q) {
      const uvec4 w = from_costs ? imageLoad(costs16, index8 / 2 + q) : imageLoad(scratch_read16, index8 / 2 + q);
      [[unroll]] for (int b = 0; b < 16; ++b) v[16 * q + b] = (w[b >> 2] >> (8 * (b & 3))) & 0xFFu;
    }
  } else {
    [[unroll]] for (int q = 0; q < K / 8; ++q) {
      const uvec2 w = (from_costs ? imageLoad(costs8, index8 + q) : imageLoad(scratch_read8, index8 + q)).xy;
      [[unroll]] for (int b = 0; b < 8; ++b) v[8 * q + b] = (w[b >> 2] >> (8 * (b & 3))) & 0xFFu;
    }
  }
}

uint packBytes(uint a, uint b, uint c, uint d) {
  // Only padded disparities exceed 255 (real ones: L <= maxCost + P2 <= 255).
  if (PADDED) return min(a, 255u) | (min(b, 255u) << 8) | (min(c, 255u) << 16) | (min(d, 255u) << 24);
  return a | (b << 8) | (c << 16) | (d << 24);
}

// Bytes 8q .. 8q + 7 of this lane's K path costs.
uint64_t scratchWord(uint v[K], int q) {
  return packUint2x32(uvec2(packBytes(v[8 * q], v[8 * q + 1], v[8 * q + 2], v[8 * q + 3]),
                            packBytes(v[8 * q + 4], v[8 * q + 5], v[8 * q + 6], v[8 * q + 7])));
}

void storeScratch(int index8, uint v[K]) {
  uint64_t words[K / 8];
  [[unroll]] for (int q = 0; q < K / 8; ++q) words[q] = scratchWord(v, q);
  if (WIDE) {
    [[unroll]] for (int q = 0; q < K / 16; ++q) scratch_write16[index8 / 2 + q] = u64vec2(words[2 * q], words[2 * q + 1]);
  } else {
    [[unroll]] for (int q = 0; q < K / 8; ++q) scratch_write8[index8 + q] = words[q];
  }
}

// Paths 0 and 1 of this lane, side by side at index8 (= scratchIndex of path 0): one store for both when they fit
// in 32 bytes.
void storeScratchPair(int index8, uint v0[K], uint v1[K]) {
  if (K == 16) {
    scratch_write32[index8 / 4] = u64vec4(scratchWord(v0, 0), scratchWord(v0, 1), scratchWord(v1, 0), scratchWord(v1, 1));
  } else if (K == 8) {
    scratch_write16[index8 / 2] = u64vec2(scratchWord(v0, 0), scratchWord(v1, 0));
  } else {
    storeScratch(index8, v0);
    storeScratch(index8 + K / 8, v1);
  }
}

int sumIndex(int y, int x) {  // this lane's first 16-byte texel of the sums of pixel (x, y)
  return ((y * pc.width + x) * int(LPP) + int(lane)) * (K / 8);
}

// Stores this lane's K sums (16 bits each) of pixel (x, y).
void storeSums(int y, int x, uint s[K]) {
  const int chunk = y / pc.rows_per_chunk;
  const int index16 = sumIndex(y - chunk * pc.rows_per_chunk, x);
  uint words[K / 2];
  [[unroll]] for (int j = 0; j < K / 2; ++j) words[j] = s[2 * j] | (s[2 * j + 1] << 16);
  if (WIDE) {
    [[unroll]] for (int q = 0; q < K / 16; ++q)
      sums32[chunk].v[index16 / 2 + q] = u64vec4(
          packUint2x32(uvec2(words[8 * q], words[8 * q + 1])), packUint2x32(uvec2(words[8 * q + 2], words[8 * q + 3])),
          packUint2x32(uvec2(words[8 * q + 4], words[8 * q + 5])), packUint2x32(uvec2(words[8 * q + 6], words[8 * q + 7])));
  } else {
    [[unroll]] for (int q = 0; q < K / 8; ++q)
      sums16[chunk].v[index16 + q] = uvec4(words[4 * q], words[4 * q + 1], words[4 * q + 2], words[4 * q + 3]);
  }
}

// s += the other pass's sums at (x, y): each half word holds at most 4 x 255, so the packed add cannot carry.
void addStoredSums(int y, int x, inout uint s[K]) {
  const int index = sumIndex(y, x);
  [[unroll]] for (int q = 0; q < K / 8; ++q) {
    const uvec4 w = imageLoad(sums_read, index + q);
    [[unroll]] for (int b = 0; b < 4; ++b) {
      s[8 * q + 2 * b] += w[b] & 0xFFFFu;
      s[8 * q + 2 * b + 1] += w[b] >> 16;
    }
  }
}

int rightDisparity(uint key) { return key == NONE ? E3D_INVALID : (MIN_DISP + int(key & 0xFFu)) * 16; }

// Results of a row, one per lane of the group: lane (x mod LPP) keeps the value of pixel x. The walk goes up
// (forward) or down (backward) one pixel at a time; a group is stored when the walk leaves it and, at the end of the
// row, by storeGathered.
void storeGathered(int gathered, int x, bool forward, int row_base, bool is_left) {
  const int slot = x & int(LPP - 1u);
  const int first = x - slot;
  const bool mine = forward ? int(lane) <= slot : int(lane) >= slot;
  const int at = first + int(lane);
  if (mine && at >= 0 && at < pc.width) {
    if (is_left) disp_left[row_base + column(at)] = gathered;
    else disp_right[row_base + at] = gathered;
  }
}
void gather(inout int gathered, int x, int v, bool forward, int row_base, bool is_left, bool on_row) {
  const int slot = x & int(LPP - 1u);
  gathered = on_row && int(lane) == slot ? v : gathered;
  if (on_row && slot == (forward ? int(LPP) - 1 : 0)) storeGathered(gathered, x, forward, row_base, is_left);
}

uint censusRight(int y, int x) { return imageLoad(census_right, y * pc.width + column(clamp(x, 0, pc.width - 1))).x; }
uint intensity(int y, int x) { return imageLoad(image_left, y * pc.width + column(clamp(x, 0, pc.width - 1))).x; }

void main() {
  lane = gl_SubgroupInvocationID % LPP;
  grp = gl_SubgroupInvocationID / LPP;
  const int pass = int(gl_WorkGroupID.x);
  const bool forward = pass == 0;
  const int W = pc.width, H = pc.height;
  const int step = forward ? 1 : -1;  // along the row and from row to row
  const int k0 = int(lane) * K;
  const uint last_lane = LPP - 1u;
  const uint group_lane0 = grp * LPP;  // the subgroup lane of this group's lane 0
  // The slot of the diagonal search that is complete after each pixel: D - 1 forward, 0 backward.
  const int done_d = forward ? D - 1 : 0;
  const int begin = forward ? pc.begin.x : pc.begin.y, end = forward ? pc.end.x : pc.end.y;
  const int x_first = forward ? 0 : W - 1, x_last = forward ? W - 1 : 0;
  for (int i0 = begin; i0 < end; i0 += G) {
    const int i = i0 + int(grp);                // this group's walk row
    const bool row_active = i < end;            // (the last rows of a part may leave groups without a row)
    const int y = forward ? min(i, end - 1) : H - 1 - min(i, end - 1);
    const int y_prev = clamp(y - step, 0, H - 1);  // the previous row of the walk (unused in its first row)
    const int read_half = i & 1, write_half = read_half ^ 1;
    const int row_base = y * W;
    // window[k] = census_right(x - d_min - (k0 + k)), x - d clamped into the row as in the reference
    uint window[K];
    [[unroll]] for (int k = 0; k < K; ++k) window[k] = COST_VOLUME ? 0u : censusRight(y, x_first - MIN_DISP - k0 - k);
    uint h_prev[K];
    [[unroll]] for (int k = 0; k < K; ++k) h_prev[k] = 0u;
    uint pixel_prev = 0u;
    // Intensities of the previous row at x - step, x, x + step (for the adaptive P2 of the row paths).
    uint row_behind = 0u, row_here = intensity(y_prev, x_first), row_ahead = intensity(y_prev, x_first + step);
    // Selection: the diagonal search, slot d holding the best (S << 8 | d) so far for xr = x - d_min - d.
    uint shift[K];
    [[unroll]] for (int k = 0; k < K; ++k) shift[k] = NONE;
    int left = E3D_INVALID, right = E3D_INVALID;
    if (PHASE == 1 && RIGHT_MAP && row_active) {
      // Right-image pixels that no left pixel reaches: [0, -d_min - D + 1) and (W - 1 - d_min, W - 1].
      for (int xr = int(lane); xr < min(W, -MIN_DISP - D + 1); xr += int(LPP)) disp_right[row_base + xr] = E3D_INVALID;
      for (int xr = max(0, W - MIN_DISP) + int(lane); xr < W; xr += int(LPP)) disp_right[row_base + xr] = E3D_INVALID;
    }
    // Group g is at walk column j - 2 g: it starts 2 g steps after group 0.
    for (int j = 0; j < W + 2 * (G - 1); ++j) {
      const int jl = j - 2 * int(grp);     // this group's walk column
      const int x = x_first + step * jl;  // and image column (outside the row while the group waits or is done)
      const bool on_row = row_active && jl >= 0 && jl < W;
      const bool moves = on_row && jl > 0;  // the state of the previous pixel slides to this one
      const int xc = clamp(x, 0, W - 1);
      if (!COST_VOLUME) {
        // The window slides by one disparity: forward (x grew by one) every disparity takes the value of the one
        // below it, backward that of the one above it.
        const uint from_below = subgroupShuffleUp(window[K - 1], 1u);
        const uint from_above = subgroupShuffleDown(window[0], 1u);
        const uint fresh = censusRight(y, xc - MIN_DISP - (forward ? 0 : int(LPP) * K - 1));
        uint slid[K];
        [[unroll]] for (int k = 0; k < K; ++k) {
          const uint lower = k == 0 ? (lane == 0u ? fresh : from_below) : window[k - 1];
          const uint upper = k == K - 1 ? (lane == last_lane ? fresh : from_above) : window[k + 1];
          slid[k] = forward ? lower : upper;
        }
        [[unroll]] for (int k = 0; k < K; ++k) window[k] = moves ? slid[k] : window[k];
      }
      const uint ahead = intensity(y_prev, xc + step);
      if (moves) {
        row_behind = row_here;
        row_here = row_ahead;
        row_ahead = ahead;
      }
      uint cost[K];
      if (COST_VOLUME) {
        loadLaneBytes(true, ((y * W + xc) * int(LPP) + int(lane)) * (K / 8), cost);
        // Disparities beyond the range (padding to whole lanes) cost 255: their path costs stay >= 255 and never
        // win a minimum against real ones (<= maxCost + P2).
        [[unroll]] for (int k = 0; k < K; ++k) cost[k] = real(k0 + k) ? cost[k] : 255u;
      } else {
        const uint centre = imageLoad(census_left, y * W + column(xc)).x;
        [[unroll]] for (int k = 0; k < K; ++k) cost[k] = real(k0 + k) ? uint(bitCount(centre ^ window[k])) : 255u;
      }
      const uint pixel = intensity(y, xc);

      uint cur[K], sum[K];
      const uint h_min = butterflyMin(laneMinimum(h_prev));
      pathStep(h_prev, cost, h_min, jl > 0 ? adaptiveP2(pixel, pixel_prev) : uint(pc.p2), cur);
      [[unroll]] for (int k = 0; k < K; ++k) {
        sum[k] = cur[k];
        h_prev[k] = on_row ? cur[k] : h_prev[k];
      }
      pixel_prev = on_row ? pixel : pixel_prev;

      uint path0[K];  // this row's costs of path 0, stored with path 1's
      // dir 0 comes from (x, y_prev), dir 1 from (x - step, y_prev), dir 2 from (x + step, y_prev).
      [[unroll]] for (int dir = 0; dir < ROW_DIRS; ++dir) {
        const int from = x + (dir == 1 ? -step : (dir == 2 ? step : 0));
        const bool inside = i > 0 && from >= 0 && from < W;  // else the path starts here: L = C
        uint prev[K];
        loadLaneBytes(false, scratchIndex(pass, read_half, dir, clamp(from, 0, W - 1)), prev);
        [[unroll]] for (int k = 0; k < K; ++k) prev[k] = inside ? prev[k] : 0u;
        const uint prev_min = butterflyMin(laneMinimum(prev));
        const uint above = dir == 0 ? row_here : (dir == 1 ? row_behind : row_ahead);
        pathStep(prev, cost, prev_min, adaptiveP2(pixel, above), cur);
        [[unroll]] for (int k = 0; k < K; ++k) sum[k] += cur[k];
        if (dir == 0 && ROW_DIRS == 1) {  // 4 paths: path 0 alone
          if (on_row) storeScratch(scratchIndex(pass, write_half, 0, xc), cur);
        } else if (dir == 0) {
          [[unroll]] for (int k = 0; k < K; ++k) path0[k] = cur[k];
        } else if (dir == 1) {
          if (on_row) storeScratchPair(scratchIndex(pass, write_half, 0, xc), path0, cur);
        } else {
          if (on_row) storeScratch(scratchIndex(pass, write_half, dir, xc), cur);
        }
      }

      if (PHASE == 0) {
        if (on_row) storeSums(y, xc, sum);
      } else {
        addStoredSums(y, xc, sum);
        // Left image: winner-takes-all, uniqueness, subpixel.
        uint local_key = NONE;
        [[unroll]] for (int k = 0; k < K; ++k)
          if (real(k0 + k)) local_key = min(local_key, (sum[k] << 8) | uint(k0 + k));
        const uint key = butterflyMin(local_key);
        const int best = int(key & 0xFFu);
        const uint best_cost = key >> 8;
        uint local_second = NONE, local_neighbours = 0u;
        [[unroll]] for (int k = 0; k < K; ++k) {
          const int d = k0 + k;
          if (real(d) && abs(d - best) > 1) local_second = min(local_second, sum[k]);
          if (real(d) && d == best - 1) local_neighbours |= sum[k] << 16;
          if (real(d) && d == best + 1) local_neighbours |= sum[k];
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
        gather(left, x, valid ? d16 : E3D_INVALID, forward, row_base, true, on_row);

        // Right image: the slots move by one disparity (forward up, backward down), this pixel's costs enter,
        // and slot done_d is complete.
        if (RIGHT_MAP) {
        const uint from_below = subgroupShuffleUp(shift[K - 1], 1u);
        const uint from_above = subgroupShuffleDown(shift[0], 1u);
        uint moved[K];
        [[unroll]] for (int k = 0; k < K; ++k) {
          const uint lower = k == 0 ? (lane == 0u ? NONE : from_below) : shift[k - 1];
          const uint upper = k == K - 1 ? (lane == last_lane ? NONE : from_above) : shift[k + 1];
          moved[k] = forward ? lower : upper;
          if (real(k0 + k)) moved[k] = min(moved[k], (sum[k] << 8) | uint(k0 + k));
        }
        [[unroll]] for (int k = 0; k < K; ++k) shift[k] = on_row ? moved[k] : shift[k];
        const uint done_forward = subgroupShuffle(shift[(D - 1) % K], group_lane0 + uint((D - 1) / K));
        const uint done_backward = subgroupShuffle(shift[0], group_lane0);
        const int xr = x - MIN_DISP - done_d;
        // (xr outside the row: garbage that no store picks up)
        gather(right, xr, rightDisparity(forward ? done_forward : done_backward), forward, row_base, false, on_row);
        }
      }
      // The next group reads this step's path costs from the scratch rows two steps later.
      if (G > 1) subgroupMemoryBarrier();
    }
    if (PHASE == 1 && row_active) {
      // The row ends: store the groups not yet stored, and the slots other than done_d (complete: no pixel of the
      // row is left to contribute).
      storeGathered(left, x_last, forward, row_base, true);
      if (RIGHT_MAP) {
        storeGathered(right, x_last - MIN_DISP - done_d, forward, row_base, false);
        [[unroll]] for (int k = 0; k < K; ++k) {
          const int d = k0 + k;
          const int xr = x_last - MIN_DISP - d;
          if (real(d) && d != done_d && xr >= 0 && xr < W) disp_right[row_base + xr] = rightDisparity(shift[k]);
        }
      }
    }
  }
}
