#pragma once
// One resolution of E3D's matching on the device: its images, census codes, maps and the data of its layout
// (LayoutPlan), the stages bound to them, and the recording of one full match (census, cost, aggregation,
// selection, median, left-right check) and of the Mutual Information table. The matcher keeps one level for
// the full resolution and, for the Mutual Information hierarchy, one per coarser pyramid level.
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "device/layout_plan.hpp"
#include "device/stages.hpp"
#include "device/vk_objects.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/vulkan_context.hpp"

namespace ips {
namespace e3d {

// Writes a device timestamp naming the work recorded since the previous one.
using Timestamp = std::function<void(const char*)>;

class MatchLevel {
 public:
  // guide_size: the size of the level below, whose checked map this level's Mutual Information table learns
  // from (empty for the coarsest level or without the hierarchy).
  MatchLevel(const VulkanContext& ctx, cv::Size size, const SgmParams& params, cv::Size guide_size = cv::Size());
  MatchLevel(const MatchLevel&) = delete;
  MatchLevel& operator=(const MatchLevel&) = delete;

  // Mutual Information hierarchy: this level's images from the level above (downsample), and its table from the
  // checked map of the level below (doubled).
  void readImagesFrom(const MatchLevel& above);
  void learnFrom(const MatchLevel& below);

  void recordDownsample(VkCommandBuffer cmd) const { downsample_->record(cmd); }
  void recordMiTable(VkCommandBuffer cmd, MiHistogramStage::Guide guide) const;
  // The matching of this level once its images (and, for mi, its table) are in place: census (census cost), each
  // match (the left one, and the mirrored second one for RightMap::match), median and left-right check; no fill.
  void recordMatching(VkCommandBuffer cmd, const Timestamp& timestamp) const;
  void recordFill(VkCommandBuffer cmd) const { fill_->record(cmd); }

  cv::Size size() const { return size_; }
  const SgmParams& params() const { return params_; }
  bool rowLayout() const { return plan_.rows; }
  // How the paths are walked at this level, e.g. "rows, 4 pixels per subgroup of 8 lanes, 16 disparities per lane".
  std::string layoutDescription() const;
  size_t memoryBytes() const { return memory_bytes_; }
  // The 8-bit images (host-visible, four pixels per word): the pair to match.
  const vk::Buffer (&images() const)[2] { return image_; }
  // The left map after median and left-right check (those enabled), before the fill; the filled map; the right
  // map (after the median when enabled). CV_32S buffers, host-visible.
  const vk::Buffer& checkedLeft() const;
  const vk::Buffer& filledLeft() const { return filled_disp_; }
  const vk::Buffer& rightMap() const { return params_.median ? median_[1] : disp_[1]; }

 private:
  void initLines();
  void initRows();
  void initCostStages(const std::vector<vk::Descriptor>& chunks, int base_row, int rows_per_chunk, int row_words);
  void initMutualInformation(cv::Size guide_size);
  void recordMatch(VkCommandBuffer cmd, int match, const Timestamp& timestamp) const;
  bool secondMatch() const { return params_.right_map == RightMap::match; }
  vk::Buffer buffer(VkDeviceSize bytes, bool host_visible) {
    return vk::Buffer(ctx_, bytes, host_visible, &memory_bytes_);
  }

  const VulkanContext& ctx_;
  VkDevice dev_;
  cv::Size size_;
  SgmParams params_;
  LayoutPlan plan_;
  size_t memory_bytes_ = 0;
  vk::DescriptorPool pool_;  // before the stages: it outlives their descriptor sets

  vk::Buffer image_[2], census_[2], disp_[2], median_[2], final_disp_, filled_disp_;
  vk::BufferView image_words_[2];  // the 8-bit images as 32-bit texels (four pixels each)
  vk::BufferView image_bytes_[2], census_words_[2], disp_texels_[2];
  std::vector<vk::Buffer> volume_;  // lines: the path-cost volume split over buffers
  vk::Buffer scratch_, sums_;       // rows: two rows of path costs per pass, the sums of both passes
  vk::Buffer costs_;                // rows, costs other than census: the cost volume
  vk::BufferView scratch16_, scratch8_, sums_texels_, costs16_, costs8_;
  // Mutual Information: the histogram (65536 bins + count), the table, work space, the log2 fractions.
  vk::Buffer mi_histogram_, mi_table_, mi_work64_, mi_work32_, mi_log2_;

  std::optional<CensusStage> census_stage_;
  // Per match (the left one, the mirrored second one): cost, then lines (aggregation, wta) or the row passes.
  std::optional<CostStage> cost_[2];
  std::optional<LineAggregationStage> aggregate_[2];
  std::optional<WtaStage> wta_[2];
  std::optional<RowPassStage> row_passes_[2];
  std::optional<MedianStage> median_stage_;
  std::optional<LrCheckStage> lr_stage_;
  std::optional<FillStage> fill_;
  std::optional<MiHistogramStage> mi_start_histogram_, mi_guided_histogram_;
  std::optional<MiTableStage> mi_table_stage_;
  std::optional<DownsampleStage> downsample_;
};

}  // namespace e3d
}  // namespace ips
