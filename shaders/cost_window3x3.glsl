// Shared by the window costs (cost_sad, cost_mi with mi_window 3): C(x,y,d) = min((sum_{dy,dx} WINDOW_PAIR_COST(
// L(x+dx,y+dy), R(x-d+dx,y+dy)) + 4) / 9, 63), every column and row clamped into the image (see
// ips/e3d/matching_cost.hpp), written into the cost volume (cost_volume.glsl). The includer defines
// WINDOW_PAIR_COST(left_grey, right_grey) (uint, 0..63) and includes this after cost_volume.glsl.
// The output pixels are pc's [x_begin, x_end) x [y_begin, y_end) (cost_mi: one region of its tables; the window
// reaches past it into the image). One workgroup (= one subgroup) per E3D_WINDOW_ROWS output rows; lane l owns disparities l*K .. l*K+K-1. The right
// greys of each row slide by one disparity per pixel; R(x - d + 1) is the neighbouring disparity d - 1 (a shuffle
// across lanes, and one extra load at the start of the range). Each pair cost is computed once and carried for two
// columns, and each row's sums serve up to three output rows of the subgroup, so a table cost (mi) is looked up
// (2 + E3D_WINDOW_ROWS) / E3D_WINDOW_ROWS times per pixel and disparity, not nine.
#ifndef COST_WINDOW3X3_GLSL
#define COST_WINDOW3X3_GLSL

void window3x3Costs() {
  const int R = E3D_WINDOW_ROWS + 2;  // image rows y0 - 1 .. y0 + E3D_WINDOW_ROWS
  const uint lane = gl_SubgroupInvocationID;
  const uint last_lane = gl_SubgroupSize - 1u;
  const int y0 = pc.y_begin + int(gl_WorkGroupID.x) * E3D_WINDOW_ROWS;
  const int x0 = pc.x_begin;
  const int k0 = int(lane) * K;
  const int span = int(gl_SubgroupSize) * K;  // disparities held by the subgroup
  uint window[R][K];   // R(x - d_min - k0 - k) of each row
  uint at_left[R][K];  // the pair costs of column x - 1 (left and right column each clamped into the image)
  uint at_x[R][K];     // and of column x: each pair cost is looked up once, as column x + 1, and then carried
  [[unroll]] for (int r = 0; r < R; ++r) {
    const int y = y0 + r - 1;
    [[unroll]] for (int k = 0; k < K; ++k) window[r][k] = grey(true, y, x0 - pc.min_disp - k0 - k);
    // Column x0 - 1: R(x0 - 1 - d) is disparity d + 1 (the next lane's first, or one load past the range).
    const uint above_lane = subgroupShuffleDown(window[r][0], 1u);
    const uint above_range = grey(true, y, x0 - pc.min_disp - span);
    const uint above = lane == last_lane ? above_range : above_lane;
    const uint l_minus = grey(false, y, x0 - 1), l_x = grey(false, y, x0);
    [[unroll]] for (int k = 0; k < K; ++k) {
      at_left[r][k] = WINDOW_PAIR_COST(l_minus, k == K - 1 ? above : window[r][k + 1]);
      at_x[r][k] = WINDOW_PAIR_COST(l_x, window[r][k]);
    }
  }
  for (int x = x0; x < pc.x_end; ++x) {
    uint row_sum[R][K];  // each row's three pair costs about column x
    [[unroll]] for (int r = 0; r < R; ++r) {
      const int y = y0 + r - 1;
      if (x > x0) {
        const uint carried = subgroupShuffleUp(window[r][K - 1], 1u);
        [[unroll]] for (int k = K - 1; k > 0; --k) window[r][k] = window[r][k - 1];
        const uint fresh = grey(true, y, x - pc.min_disp);
        window[r][0] = lane == 0u ? fresh : carried;
      }
      // Column x + 1: R(x + 1 - d) is disparity d - 1 (the lane below's last, or one load before the range).
      const uint below_lane = subgroupShuffleUp(window[r][K - 1], 1u);
      const uint below_range = grey(true, y, x - pc.min_disp + 1);
      const uint below = lane == 0u ? below_range : below_lane;
      const uint l_plus = grey(false, y, x + 1);
      [[unroll]] for (int k = 0; k < K; ++k) {
        const uint at_right = WINDOW_PAIR_COST(l_plus, k == 0 ? below : window[r][k - 1]);
        row_sum[r][k] = at_left[r][k] + at_x[r][k] + at_right;
        at_left[r][k] = at_x[r][k];
        at_x[r][k] = at_right;
      }
    }
    [[unroll]] for (int j = 0; j < E3D_WINDOW_ROWS; ++j) {
      if (y0 + j >= pc.y_end) break;  // the last subgroup of a height not a multiple of E3D_WINDOW_ROWS
      uint c[K];
      [[unroll]] for (int k = 0; k < K; ++k)
        c[k] = k0 + k < pc.num_disp ? min((row_sum[j][k] + row_sum[j + 1][k] + row_sum[j + 2][k] + 4u) / 9u, 63u)
                                    : 255u;
      storeCosts(y0 + j, x, c);
    }
  }
}
#endif
