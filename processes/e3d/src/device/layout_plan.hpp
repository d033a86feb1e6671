#pragma once
// Where E3D's device data lives: the subgroup lane layout of the disparities, the path-cost volume of the line
// layout split over buffers, the sums, scratch and cost volume of the row layout split over storage-buffer
// ranges, and how far one dispatch of the row passes may walk. Plain arithmetic on the sizes and the device's
// limits (no Vulkan calls), so it is tested on its own; the matcher allocates what the plan says.
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "ips/e3d/sgm.hpp"
#include "ips/e3d_shaders/interface.h"

namespace ips {
namespace e3d {
class VulkanContext;

constexpr int kMaxChunks = E3D_MAX_CHUNKS;
constexpr int kMaxWidth = E3D_MAX_WIDTH;
static_assert(E3D_INVALID == kInvalidDisparity, "shaders and host mark invalid disparities alike");
// lavapipe (gallivm) ends a shader invocation after 65535 loop iterations counted over all its loops; shaders that
// walk far are dispatched in parts that stay below this (with a margin for loops the compiler does not unroll).
constexpr int kMaxLoopIterations = 60000;

// What the plan needs to know of the device.
struct DeviceLimits {
  uint32_t subgroup_size = 8;
  uint64_t max_storage_buffer_range = 1ull << 27;
  uint64_t max_allocation_bytes = 1ull << 31;
  uint64_t max_texel_buffer_elements = 1ull << 27;
  bool cpu = true;         // a CPU device (lavapipe)
  bool row_layout = true;  // supports the row passes (VulkanContext::supportsRowLayout)
  static DeviceLimits of(const VulkanContext& ctx);
  // The largest storage-buffer range used (at most 2 GiB, as the shaders index with 32-bit integers).
  uint64_t maxRange() const;
};

// The disparities each subgroup lane owns (K, a multiple of `multiple`) and the range padded to whole lanes.
struct LanePlan {
  int lane_disps = 0;
  int padded_disps = 0;
};
LanePlan planLanes(int num_disparities, uint32_t subgroup_size, int multiple);

// A buffer of `rows` rows of row_bytes each, seen through kMaxChunks storage-buffer ranges of rows_per_chunk rows
// (ranges past the last one repeat it, so every array element of the shaders is bound).
struct ChunkRange {
  uint64_t offset = 0, bytes = 0;
};
std::vector<ChunkRange> rowRanges(uint64_t row_bytes, int rows, int rows_per_chunk);

// Lines: one slice of H rows per path and one for the matching costs, W x padded_disps bytes per row, split by
// rows over num_chunks buffers (chunk_bytes each).
struct LinesPlan {
  LanePlan lanes;
  uint64_t row_bytes = 0;
  int row_words = 0;
  int rows_per_chunk = 0;
  int num_chunks = 0;
  std::vector<uint64_t> chunk_bytes;
  int cost_slice = 0;     // the slice of the matching costs (after the path slices)
  int cost_base_row = 0;  // its first row
};

// Rows: the sums (16 bits per disparity) of all pixels in one allocation, written through rows_per_chunk-row
// ranges; the scratch of two rows of three paths per pass; for costs other than census a cost volume (one byte
// per disparity) written through ranges of cost_rows_per_chunk rows.
struct RowsPlan {
  LanePlan lanes;
  uint64_t sum_row_bytes = 0, sum_bytes = 0;
  int rows_per_chunk = 0;
  int num_chunks = 0;
  uint64_t scratch_bytes = 0;
  bool cost_volume = false;
  uint64_t cost_row_bytes = 0;
  int cost_rows_per_chunk = 0;
  int cost_row_words = 0;
  // The cost stage's lanes: the same padded range on all subgroup_size lanes, so that the volume is [y][x][d]
  // whatever pixels_per_subgroup the row passes take.
  LanePlan cost_lanes;
  // Pixels a subgroup works on at once (rows walked together), each on subgroup_size / pixels_per_subgroup lanes.
  int pixels_per_subgroup = 1;
  // Image rows one dispatch of a row pass walks (kMaxLoopIterations per invocation).
  int rows_per_dispatch = 0;
};

struct LayoutPlan {
  bool rows = false;  // the aggregation layout: row passes (true) or lines
  LinesPlan lines;
  RowsPlan row_passes;
};

// Plans the layout SgmParams::aggregation asks for on this device. Throws std::invalid_argument when the size is
// out of range or the data do not fit the device's buffers.
LayoutPlan planLayout(cv::Size size, const SgmParams& params, const DeviceLimits& limits);

}  // namespace e3d
}  // namespace ips
