// The matching stages: the cost stages, the line layout's aggregation and winner-takes-all, the row passes.
#include <algorithm>
#include <string>

#include "device/stages.hpp"

namespace ips {
namespace e3d {

vk::Specialisation matchSpecialisation(uint32_t subgroup_size, int lane_disps, const SgmParams& params,
                                       const MatchVariant& variant) {
  int log2_sg = 0;
  while ((1u << (log2_sg + 1)) <= subgroup_size) ++log2_sg;
  return {{E3D_SPEC_SUBGROUP_SIZE, static_cast<int32_t>(subgroup_size)},
          {E3D_SPEC_LANE_DISPARITIES, lane_disps},
          {E3D_SPEC_NUM_DISPARITIES, params.num_disparities},
          {E3D_SPEC_NUM_PATHS, params.paths},
          {E3D_SPEC_LOG2_SUBGROUP_SIZE, log2_sg},
          {E3D_SPEC_MIN_DISPARITY, params.min_disparity},
          {E3D_SPEC_PHASE, variant.phase},
          {E3D_SPEC_MIRROR, variant.mirror ? 1 : 0},
          {E3D_SPEC_RIGHT_MAP, variant.right_map ? 1 : 0},
          {E3D_SPEC_COST_VOLUME, variant.cost_volume ? 1 : 0},
          {E3D_SPEC_MI_WINDOW, params.mi_window},
          {E3D_SPEC_ROW_PIXELS, variant.row_pixels}};
}

CostStage CostStage::census(const vk::DescriptorPool& pool, const vk::Specialisation& spec, cv::Size size,
                            const SgmParams& params, const vk::Buffer& census_left, const vk::Buffer& census_right,
                            const std::vector<vk::Descriptor>& chunks, const LinesPlan& plan) {
  CostStage stage(vk::Pipeline(pool, "cost_census", {{2, census_left}, {3, census_right}, {4, chunks}},
                               sizeof(shader::CensusCostParams), spec),
                  size.height);
  stage.census_ = true;
  stage.census_pc_ = {size.width,      size.height,         params.num_disparities, params.min_disparity,
                      plan.cost_slice, plan.rows_per_chunk, plan.row_words};
  return stage;
}

CostStage CostStage::intensity(const vk::DescriptorPool& pool, const vk::Specialisation& spec, cv::Size size,
                               const SgmParams& params, const vk::BufferView& image_left,
                               const vk::BufferView& image_right, const std::vector<vk::Descriptor>& chunks,
                               const vk::Buffer* mi_table, int base_row, int rows_per_chunk, int row_words) {
  const bool mi = params.cost == Cost::mi;
  std::vector<vk::Binding> bindings = {{0, image_left}, {1, image_right}, {4, chunks}};
  if (mi) bindings.push_back(vk::Binding::dynamicUniformBuffer(5, *mi_table, E3D_MI_TABLE_BYTES));
  const int rows_per_group = isWindowCost(params) ? E3D_WINDOW_ROWS : 1;
  CostStage stage(vk::Pipeline(pool, std::string("cost_") + toString(params.cost), bindings,
                               sizeof(shader::CostVolumeParams), spec),
                  0);
  // The regions' pixels; the mirrored match (the second) walks the mirrored image, so region column i covers the
  // mirrored columns [W - x_end, W - x_begin).
  const bool mirrored = std::any_of(spec.begin(), spec.end(), [](const std::pair<uint32_t, int32_t>& s) {
    return s.first == E3D_SPEC_MIRROR && s.second != 0;
  });
  const int columns = mi ? params.mi_region_columns : 1, rows = mi ? params.mi_region_rows : 1;
  const int W = size.width, H = size.height;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < columns; ++i) {
      const int x_begin = E3D_REGION_BEGIN(i, columns, W), x_end = E3D_REGION_BEGIN(i + 1, columns, W);
      const int y_begin = E3D_REGION_BEGIN(j, rows, H), y_end = E3D_REGION_BEGIN(j + 1, rows, H);
      Part part;
      part.pc = {W,
                 H,
                 params.num_disparities,
                 params.min_disparity,
                 base_row,
                 rows_per_chunk,
                 row_words,
                 mirrored ? W - x_end : x_begin,
                 mirrored ? W - x_begin : x_end,
                 y_begin,
                 y_end};
      part.table_offset = static_cast<uint32_t>((j * columns + i) * E3D_MI_TABLE_BYTES);
      part.groups = (y_end - y_begin + rows_per_group - 1) / rows_per_group;
      if (x_end > x_begin && part.groups > 0) stage.parts_.push_back(part);
    }
  return stage;
}

void CostStage::record(VkCommandBuffer cmd) const {
  if (census_) {
    pipeline_.bind(cmd);
    pipeline_.push(cmd, census_pc_);
    vkCmdDispatch(cmd, static_cast<uint32_t>(groups_), 1, 1);
  }
  // The regions write disjoint pixels of the volume: no barrier between them.
  for (const Part& part : parts_) {
    pipeline_.bind(cmd, part.table_offset);
    pipeline_.push(cmd, part.pc);
    vkCmdDispatch(cmd, static_cast<uint32_t>(part.groups), 1, 1);
  }
  vk::computeBarrier(cmd);
}

LineAggregationStage::LineAggregationStage(const vk::DescriptorPool& pool, const vk::Specialisation& spec,
                                           cv::Size size, const SgmParams& params, const vk::Buffer& image_left,
                                           const std::vector<vk::Descriptor>& chunks, const LinesPlan& plan)
    : pipeline_(pool, "sgm_aggregate", {{0, image_left}, {4, chunks}}, sizeof(shader::AggregateParams), spec),
      pc_{size.width,  size.height, params.num_disparities, params.min_disparity,
          params.p1,   params.p2,   params.p2_slope,        0,
          0,           0,           plan.rows_per_chunk,    plan.row_words,
          params.paths},
      paths_(params.paths) {}

void LineAggregationStage::record(VkCommandBuffer cmd) const {
  pipeline_.bind(cmd);
  for (int r = 0; r < paths_; ++r) {
    shader::AggregateParams pc = pc_;
    pc.path = r;
    pc.dx = kPathDirections[r][0];
    pc.dy = kPathDirections[r][1];
    pipeline_.push(cmd, pc);
    const int lines = pc.dy == 0 ? pc.height : (pc.dx == 0 ? pc.width : pc.width + pc.height - 1);
    vkCmdDispatch(cmd, static_cast<uint32_t>(lines), 1, 1);
  }
  vk::computeBarrier(cmd);
}

WtaStage::WtaStage(const vk::DescriptorPool& pool, const vk::Specialisation& spec, cv::Size size,
                   const SgmParams& params, const std::vector<vk::Descriptor>& chunks, const vk::Buffer& disp_left,
                   const vk::Buffer& disp_right, const LinesPlan& plan)
    : pipeline_(pool, "sgm_wta", {{4, chunks}, {5, disp_left}, {6, disp_right}}, sizeof(shader::WtaParams), spec),
      pc_{size.width,    size.height,       params.num_disparities,  params.min_disparity,
          params.paths,  params.uniqueness, params.subpixel ? 1 : 0, plan.rows_per_chunk,
          plan.row_words} {}

void WtaStage::record(VkCommandBuffer cmd) const {
  pipeline_.bind(cmd);
  pipeline_.push(cmd, pc_);
  vkCmdDispatch(cmd, static_cast<uint32_t>(pc_.height), 1, 1);  // one subgroup per row
  vk::computeBarrier(cmd);
}

RowPassStage::RowPassStage(const vk::DescriptorPool& pool, uint32_t subgroup_size, cv::Size size,
                           const SgmParams& params, const Buffers& b, const RowsPlan& plan, MatchVariant variant)
    : pc_{size.width,
          size.height,
          params.p1,
          params.p2,
          params.p2_slope,
          plan.rows_per_chunk,
          params.uniqueness,
          params.subpixel ? 1 : 0,
          {0, 0},
          {0, 0}},
      rows_per_dispatch_(plan.rows_per_dispatch) {
  const std::vector<vk::Binding> bindings = {
      {0, b.image_left}, {1, b.census_left}, {2, b.census_right}, {3, b.scratch16},  {4, b.scratch8}, {5, b.scratch},
      {6, b.sum_chunks}, {7, b.sums},        {8, b.disp_left},    {9, b.disp_right}, {10, b.costs16}, {11, b.costs8}};
  variant.cost_volume = plan.cost_volume;
  variant.row_pixels = plan.pixels_per_subgroup;
  for (int phase = 0; phase < 2; ++phase) {
    variant.phase = phase;
    phases_[phase] = vk::Pipeline(pool, "sgm_aggregate_rowpass", bindings, sizeof(shader::RowPassParams),
                                  matchSpecialisation(subgroup_size, plan.lanes.lane_disps, params, variant));
  }
}

void RowPassStage::record(VkCommandBuffer cmd, int phase) const {
  const int H = pc_.height, split = H / 2;
  // Walk rows (forward: image row i, backward: image row H - 1 - i) of the two phases.
  const int phase_begin[2][2] = {{0, 0}, {split, H - split}};
  const int phase_end[2][2] = {{split, H - split}, {H, H}};
  const vk::Pipeline& pipeline = phases_[phase];
  pipeline.bind(cmd);
  shader::RowPassParams pc = pc_;
  int32_t* begin[2] = {&pc.begin.x, &pc.begin.y};
  int32_t* end[2] = {&pc.end.x, &pc.end.y};
  for (int part = 0;; ++part) {
    bool any = false;
    for (int p = 0; p < 2; ++p) {
      *begin[p] = std::min(phase_begin[phase][p] + part * rows_per_dispatch_, phase_end[phase][p]);
      *end[p] = std::min(*begin[p] + rows_per_dispatch_, phase_end[phase][p]);
      any = any || *end[p] > *begin[p];
    }
    if (!any) break;
    pipeline.push(cmd, pc);
    vkCmdDispatch(cmd, 2, 1, 1);  // the forward and the backward pass
    vk::computeBarrier(cmd);
  }
}

}  // namespace e3d
}  // namespace ips
