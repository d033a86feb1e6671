#include "device/match_level.hpp"

#include <cstring>
#include <string>

namespace ips {
namespace e3d {

namespace {

// kMaxChunks storage-buffer descriptors over the row ranges of one buffer.
std::vector<vk::Descriptor> rangeDescriptors(const vk::Buffer& buffer, uint64_t row_bytes, int rows,
                                             int rows_per_chunk) {
  std::vector<vk::Descriptor> descriptors;
  for (const ChunkRange& r : rowRanges(row_bytes, rows, rows_per_chunk))
    descriptors.push_back({buffer.handle(), r.offset, r.bytes});
  return descriptors;
}

}  // namespace

MatchLevel::MatchLevel(const VulkanContext& ctx, cv::Size size, const SgmParams& params, cv::Size guide_size)
    : ctx_(ctx),
      dev_(ctx.device()),
      size_(size),
      params_(params),
      plan_(planLayout(size, params, DeviceLimits::of(ctx))),
      pool_(ctx, 24, 10 * kMaxChunks + 64, 48, 4) {
  const size_t pixels = static_cast<size_t>(size.area());
  for (int i = 0; i < 2; ++i) {
    image_[i] = buffer((pixels + 3) / 4 * 4, true);
    census_[i] = buffer(pixels * 4, false);
    disp_[i] = buffer(pixels * 4, true);
    median_[i] = buffer(pixels * 4, true);
    image_words_[i] = vk::BufferView(dev_, image_[i], VK_FORMAT_R32_UINT);
    disp_texels_[i] = vk::BufferView(dev_, disp_[i], VK_FORMAT_R32_SINT);
  }
  final_disp_ = buffer(pixels * 4, true);
  filled_disp_ = buffer(pixels * 4, true);

  census_stage_.emplace(pool_, size_, image_words_, census_);
  if (params_.cost == Cost::mi) initMutualInformation(guide_size);
  if (plan_.rows)
    initRows();
  else
    initLines();
  median_stage_.emplace(pool_, size_, disp_texels_, median_);
  const vk::Buffer* lr_in = params_.median ? median_ : disp_;
  lr_stage_.emplace(pool_, size_, lr_in[0], lr_in[1], final_disp_, params_.lr_max_diff);
  fill_.emplace(pool_, size_, checkedLeft(), filled_disp_);
}

std::string MatchLevel::layoutDescription() const {
  const int sg = static_cast<int>(ctx_.subgroupSize());
  if (!plan_.rows)
    return "lines, " + std::to_string(sg) + " lanes per line, " + std::to_string(plan_.lines.lanes.lane_disps) +
           " disparities per lane";
  const RowsPlan& rows = plan_.row_passes;
  return "rows, " + std::to_string(rows.pixels_per_subgroup) + " pixel(s) per subgroup of " + std::to_string(sg) +
         " lanes, " + std::to_string(rows.lanes.lane_disps) + " disparities per lane";
}

const vk::Buffer& MatchLevel::checkedLeft() const {
  return params_.lr_max_diff >= 0 ? final_disp_ : (params_.median ? median_[0] : disp_[0]);
}

// Lines: costs stored once in a slice of the volume, one dispatch per path, one subgroup per image line, each
// path's costs in its own slice (one byte per disparity), summed by sgm_wta.
void MatchLevel::initLines() {
  const LinesPlan& plan = plan_.lines;
  for (uint64_t bytes : plan.chunk_bytes) volume_.push_back(buffer(bytes, false));
  std::vector<vk::Descriptor> chunks;
  for (int i = 0; i < kMaxChunks; ++i) chunks.push_back({volume_[std::min<int>(i, plan.num_chunks - 1)].handle()});
  for (int m = 0; m < (secondMatch() ? 2 : 1); ++m) {
    // The second match reads the images swapped (and mirrored, in the shaders) and its left map is the right one.
    const vk::Specialisation spec =
        matchSpecialisation(ctx_.subgroupSize(), plan.lanes.lane_disps, params_, {0, m == 1, !secondMatch()});
    if (params_.cost == Cost::census)
      cost_[m] = CostStage::census(pool_, spec, size_, params_, census_[m], census_[1 - m], chunks, plan);
    aggregate_[m].emplace(pool_, spec, size_, params_, image_[m], chunks, plan);
    wta_[m].emplace(pool_, spec, size_, params_, chunks, disp_[m], disp_[1], plan);
  }
  if (params_.cost != Cost::census) initCostStages(chunks, plan.cost_base_row, plan.rows_per_chunk, plan.row_words);
}

// Rows: two row passes (forward, backward) with the costs computed on the fly (census) or read from the cost
// volume, and the winner-takes-all fused in. See sgm_aggregate_rowpass.comp.
void MatchLevel::initRows() {
  const RowsPlan& plan = plan_.row_passes;
  const int H = size_.height;
  sums_ = buffer(plan.sum_bytes, false);
  scratch_ = buffer(plan.scratch_bytes, false);
  const std::vector<vk::Descriptor> sum_chunks = rangeDescriptors(sums_, plan.sum_row_bytes, H, plan.rows_per_chunk);
  scratch16_ = vk::BufferView(dev_, scratch_, VK_FORMAT_R32G32B32A32_UINT);
  scratch8_ = vk::BufferView(dev_, scratch_, VK_FORMAT_R32G32_UINT);
  sums_texels_ = vk::BufferView(dev_, sums_, VK_FORMAT_R32G32B32A32_UINT);
  for (int i = 0; i < 2; ++i) {
    image_bytes_[i] = vk::BufferView(dev_, image_[i], VK_FORMAT_R8_UINT);
    census_words_[i] = vk::BufferView(dev_, census_[i], VK_FORMAT_R32_UINT);
  }
  if (plan.cost_volume) {
    // The cost volume [y][x][lane][K bytes], written by the cost stage through storage-buffer ranges and read by
    // the row passes as texels.
    costs_ = buffer(plan.cost_row_bytes * H, false);
    costs16_ = vk::BufferView(dev_, costs_, VK_FORMAT_R32G32B32A32_UINT);
    costs8_ = vk::BufferView(dev_, costs_, VK_FORMAT_R32G32_UINT);
    initCostStages(rangeDescriptors(costs_, plan.cost_row_bytes, H, plan.cost_rows_per_chunk), 0,
                   plan.cost_rows_per_chunk, plan.cost_row_words);
  }
  for (int m = 0; m < (secondMatch() ? 2 : 1); ++m) {
    // The second match reads the images swapped (and mirrored, in the shader) and its left map is the right one.
    const RowPassStage::Buffers buffers{image_bytes_[m],
                                        census_words_[m],
                                        census_words_[1 - m],
                                        scratch16_,
                                        scratch8_,
                                        scratch_,
                                        sum_chunks,
                                        sums_texels_,
                                        disp_[m],
                                        disp_[1],
                                        plan.cost_volume ? costs16_ : scratch16_,
                                        plan.cost_volume ? costs8_ : scratch8_};
    row_passes_[m].emplace(pool_, ctx_.subgroupSize(), size_, params_, buffers, plan,
                           MatchVariant{0, m == 1, !secondMatch()});
  }
}

// The cost stage of each match for the costs other than census (cost_ad, cost_sad, cost_mi): they write the cost
// volume of the row layout or the cost slice of the line layout.
void MatchLevel::initCostStages(const std::vector<vk::Descriptor>& chunks, int base_row, int rows_per_chunk,
                                int row_words) {
  const int lane_disps = plan_.rows ? plan_.row_passes.cost_lanes.lane_disps : plan_.lines.lanes.lane_disps;
  for (int m = 0; m < (secondMatch() ? 2 : 1); ++m) {
    const vk::Specialisation spec =
        matchSpecialisation(ctx_.subgroupSize(), lane_disps, params_, {0, m == 1, !secondMatch()});
    cost_[m] = CostStage::intensity(pool_, spec, size_, params_, image_words_[m], image_words_[1 - m], chunks,
                                    &mi_table_, base_row, rows_per_chunk, row_words);
  }
}

// Mutual Information: the histograms (one per region) from this level's start disparity or own checked map and the
// tables. The histogram from the level below is wired by learnFrom.
void MatchLevel::initMutualInformation(cv::Size guide_size) {
  const int regions = params_.mi_region_columns * params_.mi_region_rows;
  mi_histogram_ = buffer(static_cast<size_t>(regions) * E3D_MI_HISTOGRAM_ENTRIES * 4, false);
  mi_table_ = buffer(static_cast<size_t>(regions) * E3D_MI_TABLE_BYTES, false);
  mi_work64_ = buffer(static_cast<size_t>(regions) * E3D_MI_WORK64_ENTRIES * 8, false);
  mi_work32_ = buffer(static_cast<size_t>(regions) * E3D_MI_WORK32_ENTRIES * 4, false);
  mi_log2_ = buffer(256 * 4, true);
  std::memcpy(mi_log2_.mapped(), log2FractionTable().data(), 256 * 4);
  mi_start_histogram_.emplace(pool_, size_, guide_size, image_words_, checkedLeft(), mi_histogram_, params_);
  mi_table_stage_.emplace(pool_, mi_histogram_, mi_log2_, mi_work64_, mi_work32_, mi_table_, regions);
}

void MatchLevel::readImagesFrom(const MatchLevel& above) {
  downsample_.emplace(pool_, above.size_, size_, above.image_words_, image_);
}

void MatchLevel::learnFrom(const MatchLevel& below) {
  mi_guided_histogram_.emplace(pool_, size_, below.size_, image_words_, below.checkedLeft(), mi_histogram_, params_);
}

void MatchLevel::recordMiTable(VkCommandBuffer cmd, MiHistogramStage::Guide guide) const {
  const auto& histogram = guide == MiHistogramStage::Guide::below ? mi_guided_histogram_ : mi_start_histogram_;
  histogram->record(cmd, guide);
  mi_table_stage_->record(cmd);
}

void MatchLevel::recordMatch(VkCommandBuffer cmd, int match, const Timestamp& timestamp) const {
  const std::string label = match == 0 ? "" : "right_";
  auto stamp = [&](const char* name) { timestamp((label + name).c_str()); };
  if (cost_[match]) {  // lines: census into the cost slice; rows and lines: the other costs
    cost_[match]->record(cmd);
    stamp("cost");
  }
  if (plan_.rows) {
    row_passes_[match]->record(cmd, 0);
    stamp("aggregate");
    row_passes_[match]->record(cmd, 1);
    stamp("aggregate_select");
    return;
  }
  aggregate_[match]->record(cmd);
  stamp("aggregate");
  wta_[match]->record(cmd);
  stamp("wta");
}

void MatchLevel::recordMatching(VkCommandBuffer cmd, const Timestamp& timestamp) const {
  if (params_.cost == Cost::census) {
    census_stage_->record(cmd);
    timestamp("census");
  }
  recordMatch(cmd, 0, timestamp);
  if (secondMatch()) recordMatch(cmd, 1, timestamp);
  if (params_.median) {
    median_stage_->record(cmd);
    timestamp("median");
  }
  if (params_.lr_max_diff >= 0) {
    lr_stage_->record(cmd);
    timestamp("lr_check");
  }
}

}  // namespace e3d
}  // namespace ips
