// Push constants of the matching stages: the cost stages, the line layout's aggregation and winner-takes-all,
// the row passes, and the Mutual Information histogram.
#ifndef IPS_E3D_SHADERS_MATCH_STAGES_H
#define IPS_E3D_SHADERS_MATCH_STAGES_H
#include "ips/e3d_shaders/interface.h"
// The push-constant macros expand to GLSL blocks whose instance name follows the brace: keep it there.
// clang-format off
E3D_INTERFACE_BEGIN

#if defined(__cplusplus) || defined(E3D_CENSUS_COST_PARAMS)
// cost_census (lines): census costs into the cost slice of the path-cost volume.
E3D_PUSH_CONSTANTS(CensusCostParams) {
  int width, height, num_disp, min_disp;
  int cost_slice, rows_per_chunk, row_words;  // volume addressing: row g = cost_slice * height + y
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(CensusCostParams, 28);
#endif

#if defined(__cplusplus) || defined(E3D_COST_VOLUME_PARAMS)
// cost_ad, cost_sad, cost_mi: costs into the cost volume (rows) or the cost slice (lines), of the pixels
// [x_begin, x_end) x [y_begin, y_end) (cost_mi: one Mutual Information region per dispatch; the others: the image).
E3D_PUSH_CONSTANTS(CostVolumeParams) {
  int width, height, num_disp, min_disp;
  int base_row, rows_per_chunk, row_words;  // row g = base_row + y
  int x_begin, x_end, y_begin, y_end;
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(CostVolumeParams, 44);
#endif

#if defined(__cplusplus) || defined(E3D_AGGREGATE_PARAMS)
// sgm_aggregate (lines): one path direction.
E3D_PUSH_CONSTANTS(AggregateParams) {
  int width, height, num_disp, min_disp;
  int p1, p2, p2_slope, path;
  int dx, dy, rows_per_chunk, row_words;  // volume addressing: row g = slice * height + y
  int cost_slice;
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(AggregateParams, 52);
#endif

#if defined(__cplusplus) || defined(E3D_WTA_PARAMS)
// sgm_wta (lines).
E3D_PUSH_CONSTANTS(WtaParams) {
  int width, height, num_disp, min_disp;
  int num_paths, uniqueness, subpixel, rows_per_chunk;
  int row_words;
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(WtaParams, 36);
#endif

#if defined(__cplusplus) || defined(E3D_ROW_PASS_PARAMS)
// sgm_aggregate_rowpass (rows): rows [begin, end) of the forward (x) and backward (y) pass.
E3D_PUSH_CONSTANTS(RowPassParams) {
  int width, height, p1, p2;
  int p2_slope, rows_per_chunk, uniqueness, subpixel;
  ivec2 begin, end;
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(RowPassParams, 48);
#ifdef __cplusplus
static_assert(offsetof(RowPassParams, begin) == 32 && offsetof(RowPassParams, end) == 40,
              "RowPassParams: ivec2 members must sit at multiples of 8 as in GLSL");
#endif
#endif

#if defined(__cplusplus) || defined(E3D_MI_HISTOGRAM_PARAMS)
// mi_histogram: mode 0 from the start disparity, 1 from this level's map, 2 from the map of the level below; one
// histogram per region of a region_columns x region_rows grid.
E3D_PUSH_CONSTANTS(MiHistogramParams) {
  int width, height, guide_width, guide_height;
  int mode, min_disp, num_disp, region_columns;
  int region_rows;
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(MiHistogramParams, 36);
#endif

E3D_INTERFACE_END
// clang-format on
#endif
