#pragma once
// E3D's device stages, one class per shader (or pair of specialisations of one shader). Each owns its pipeline
// and descriptor set (bound to the buffers given at construction) and records its dispatches, with a barrier
// after them, into a command buffer. Push constants are the structs of ips/e3d_shaders/*.h, which the shaders
// include too; specialisation-constant ids come from ips/e3d_shaders/interface.h.
#include <opencv2/core.hpp>
#include <vector>

#include "device/layout_plan.hpp"
#include "device/vk_objects.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d_shaders/image_stages.h"
#include "ips/e3d_shaders/match_stages.h"

namespace ips {
namespace e3d {

// The specialisation of the matching stages (cost, aggregation, winner-takes-all, row passes).
struct MatchVariant {
  int phase = 0;             // row passes: 0 store the sums, 1 add them and select
  bool mirror = false;       // the second match (right to left)
  bool right_map = true;     // the diagonal search for the right map
  bool cost_volume = false;  // row passes: costs from the cost volume (RowPassStage: from its plan)
  int row_pixels = 1;        // row passes: pixels per subgroup (RowPassStage: RowsPlan::pixels_per_subgroup)
};
vk::Specialisation matchSpecialisation(uint32_t subgroup_size, int lane_disps, const SgmParams& params,
                                       const MatchVariant& variant);

// census5x5: 24-bit census codes of both images (texels of four pixels) into two buffers.
class CensusStage {
 public:
  CensusStage(const vk::DescriptorPool& pool, cv::Size size, const vk::BufferView (&image_words)[2],
              const vk::Buffer (&census)[2]);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline pipeline_;
  cv::Size size_;
};

// median3x3: both maps (read as texels) into two buffers.
class MedianStage {
 public:
  MedianStage(const vk::DescriptorPool& pool, cv::Size size, const vk::BufferView (&maps)[2],
              const vk::Buffer (&out)[2]);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline pipeline_;
  cv::Size size_;
};

// lr_check: the left map, invalid where the right map disagrees by more than max_diff px.
class LrCheckStage {
 public:
  LrCheckStage(const vk::DescriptorPool& pool, cv::Size size, const vk::Buffer& left, const vk::Buffer& right,
               const vk::Buffer& out, int max_diff);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline pipeline_;
  shader::LrCheckParams pc_;
};

// fill_invalid: background fill of the invalid pixels of a map along its rows (the last stage: no barrier).
class FillStage {
 public:
  FillStage(const vk::DescriptorPool& pool, cv::Size size, const vk::Buffer& in, const vk::Buffer& out);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline pipeline_;
  cv::Size size_;
};

// rectify: bilinear remap of the raw pair times the flat-field gain (maps: map0x, map0y, map1x, map1y, gain0, gain1
// of the rectified size, floats).
class RectifyStage {
 public:
  RectifyStage(const vk::DescriptorPool& pool, cv::Size size, cv::Size raw_size, const vk::Buffer (&raw)[2],
               const vk::Buffer& maps, const vk::Buffer (&out)[2]);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline pipeline_;
  shader::RectifyParams pc_;
};

// downsample: the 2x2 means of both images of the level above into this level's images.
class DownsampleStage {
 public:
  DownsampleStage(const vk::DescriptorPool& pool, cv::Size source_size, cv::Size size,
                  const vk::BufferView (&source_words)[2], const vk::Buffer (&out)[2]);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline pipeline_;
  shader::DownsampleParams pc_;
  cv::Size size_;
};

// mi_histogram: the joint histograms (zeroed first) of the matched pixels of a disparity map (the guide: this
// level's map, or the map of the level below, doubled, or none: the start disparity), one per region of
// params.mi_region_columns x mi_region_rows.
class MiHistogramStage {
 public:
  enum class Guide { start = 0, own = 1, below = 2 };
  MiHistogramStage(const vk::DescriptorPool& pool, cv::Size size, cv::Size guide_size,
                   const vk::BufferView (&image_words)[2], const vk::Buffer& guide, const vk::Buffer& histogram,
                   const SgmParams& params);
  void record(VkCommandBuffer cmd, Guide guide) const;

 private:
  vk::Pipeline pipeline_;
  const vk::Buffer& histogram_;
  shader::MiHistogramParams pc_;
};

// mi_table: the 256 x 256 cost table of each region from its histogram, in four dispatches (mi_table.comp's steps)
// over all regions. work64 and work32 hold E3D_MI_WORK64_ENTRIES and E3D_MI_WORK32_ENTRIES entries per region.
class MiTableStage {
 public:
  MiTableStage(const vk::DescriptorPool& pool, const vk::Buffer& histogram, const vk::Buffer& log2_fractions,
               const vk::Buffer& work64, const vk::Buffer& work32, const vk::Buffer& table, int regions);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline steps_[E3D_MI_TABLE_STEPS];
  int regions_;
};

// The cost stage of one match: census costs into the lines' cost slice (cost_census), or the intensity costs
// (cost_ad, cost_sad, cost_mi) into the rows' cost volume or the lines' cost slice. One subgroup per row, or per
// E3D_WINDOW_ROWS rows for the 3x3 window costs.
class CostStage {
 public:
  // cost_census from the census codes of both images (swapped for the mirrored match).
  static CostStage census(const vk::DescriptorPool& pool, const vk::Specialisation& spec, cv::Size size,
                          const SgmParams& params, const vk::Buffer& census_left, const vk::Buffer& census_right,
                          const std::vector<vk::Descriptor>& chunks, const LinesPlan& plan);
  // cost_<cost> from the images (four pixels per texel); mi reads each region's table (params.mi_region_columns x
  // mi_region_rows, E3D_MI_TABLE_BYTES each in mi_tables) as a uniform buffer, one dispatch per region.
  static CostStage intensity(const vk::DescriptorPool& pool, const vk::Specialisation& spec, cv::Size size,
                             const SgmParams& params, const vk::BufferView& image_left,
                             const vk::BufferView& image_right, const std::vector<vk::Descriptor>& chunks,
                             const vk::Buffer* mi_table, int base_row, int rows_per_chunk, int row_words);
  void record(VkCommandBuffer cmd) const;

 private:
  // One dispatch: the pixels [x_begin, x_end) x [y_begin, y_end) of its push constants, the table at
  // table_offset (mi: one dispatch per region; the other costs: one for the image).
  struct Part {
    shader::CostVolumeParams pc;
    uint32_t table_offset;
    int groups;
  };
  CostStage(vk::Pipeline pipeline, int groups) : pipeline_(std::move(pipeline)), groups_(groups) {}
  vk::Pipeline pipeline_;
  bool census_ = false;
  shader::CensusCostParams census_pc_{};
  std::vector<Part> parts_;
  int groups_;  // workgroups of the census dispatch
};

// sgm_aggregate (lines): one dispatch per path direction, one subgroup per image line.
class LineAggregationStage {
 public:
  LineAggregationStage(const vk::DescriptorPool& pool, const vk::Specialisation& spec, cv::Size size,
                       const SgmParams& params, const vk::Buffer& image_left, const std::vector<vk::Descriptor>& chunks,
                       const LinesPlan& plan);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline pipeline_;
  shader::AggregateParams pc_;
  int paths_;
};

// sgm_wta (lines): sums the path slices, selects, and searches the right map; one subgroup per row.
class WtaStage {
 public:
  WtaStage(const vk::DescriptorPool& pool, const vk::Specialisation& spec, cv::Size size, const SgmParams& params,
           const std::vector<vk::Descriptor>& chunks, const vk::Buffer& disp_left, const vk::Buffer& disp_right,
           const LinesPlan& plan);
  void record(VkCommandBuffer cmd) const;

 private:
  vk::Pipeline pipeline_;
  shader::WtaParams pc_;
};

// sgm_aggregate_rowpass (rows): the forward and the backward pass as the two workgroups of each dispatch; phase 0
// walks each pass over its first half of the image storing the sums, phase 1 over the other half adding the
// stored sums and selecting. Each phase is dispatched in parts of at most plan.rows_per_dispatch rows.
class RowPassStage {
 public:
  struct Buffers {
    const vk::BufferView& image_left;  // R8
    const vk::BufferView& census_left;
    const vk::BufferView& census_right;
    const vk::BufferView& scratch16;
    const vk::BufferView& scratch8;
    const vk::Buffer& scratch;
    const std::vector<vk::Descriptor>& sum_chunks;
    const vk::BufferView& sums;
    const vk::Buffer& disp_left;
    const vk::Buffer& disp_right;
    const vk::BufferView& costs16;  // the cost volume (census: any texel view, unused)
    const vk::BufferView& costs8;
  };
  RowPassStage(const vk::DescriptorPool& pool, uint32_t subgroup_size, cv::Size size, const SgmParams& params,
               const Buffers& buffers, const RowsPlan& plan, MatchVariant variant);  // cost_volume, row_pixels: plan's
  void record(VkCommandBuffer cmd, int phase) const;

 private:
  vk::Pipeline phases_[2];
  shader::RowPassParams pc_;
  int rows_per_dispatch_;
};

}  // namespace e3d
}  // namespace ips
