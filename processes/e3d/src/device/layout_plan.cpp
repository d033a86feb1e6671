#include "device/layout_plan.hpp"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "ips/e3d/vulkan_context.hpp"

namespace ips {
namespace e3d {

namespace {

LinesPlan planLines(cv::Size size, const SgmParams& params, const DeviceLimits& limits) {
  const int W = size.width, H = size.height;
  LinesPlan plan;
  plan.lanes = planLanes(params.num_disparities, limits.subgroup_size, 4);
  plan.row_bytes = static_cast<uint64_t>(W) * plan.lanes.padded_disps;
  plan.row_words = static_cast<int>(plan.row_bytes / 4);
  const uint64_t max_range = limits.maxRange();
  if (plan.row_bytes > max_range) throw std::invalid_argument("StereoMatcher: one row of path costs exceeds a buffer");
  const int total_rows = (params.paths + 1) * H;  // path slices, then the matching-cost slice
  const int max_rows = static_cast<int>(max_range / plan.row_bytes);
  plan.num_chunks = (total_rows + max_rows - 1) / max_rows;
  if (plan.num_chunks > kMaxChunks)
    throw std::invalid_argument("StereoMatcher: path-cost volume too large for " + std::to_string(kMaxChunks) +
                                " buffers of maxStorageBufferRange (reduce size or num_disparities)");
  plan.rows_per_chunk = (total_rows + plan.num_chunks - 1) / plan.num_chunks;
  for (int c = 0; c < plan.num_chunks; ++c) {
    const int rows_here = std::min(plan.rows_per_chunk, total_rows - c * plan.rows_per_chunk);
    plan.chunk_bytes.push_back(static_cast<uint64_t>(rows_here) * plan.row_bytes);
  }
  plan.cost_slice = params.paths;
  plan.cost_base_row = params.paths * H;
  return plan;
}

RowsPlan planRows(cv::Size size, const SgmParams& params, const DeviceLimits& limits) {
  const int W = size.width, H = size.height;
  RowsPlan plan;
  plan.cost_volume = params.cost != Cost::census;
  const int sg = static_cast<int>(limits.subgroup_size);
  // K: a multiple of 8 (8-byte scratch accesses); with a cost volume, whose cost stage puts K * lanes_per_pixel /
  // subgroup_size disparities on each of its lanes in 4-byte words, also of 4 x pixels_per_subgroup.
  const auto lanesFor = [&](int pixels) {
    return planLanes(params.num_disparities, static_cast<uint32_t>(sg / pixels),
                     plan.cost_volume ? std::max(8, 4 * pixels) : 8);
  };
  if (params.row_pixels > 0) {
    if (params.row_pixels > sg)
      throw std::invalid_argument("StereoMatcher: row_pixels " + std::to_string(params.row_pixels) +
                                  " exceeds the subgroup size " + std::to_string(sg));
    plan.pixels_per_subgroup = params.row_pixels;
  } else {
    // The least padding of the range with at most 32 disparities per lane (more spill registers); among equal
    // paddings the most pixels whose lanes hold at most 16, else the fewest pixels. Measured on lavapipe (640x480, 8
    // paths, processes/e3d/README.md "Speed"): most of a pixel's cost does not grow with its disparities, so more
    // pixels per subgroup are faster while the lanes hold up to 16-24 disparities; at 32 they were as fast as half as
    // many pixels with 16, at 40 no faster, at 64 slower.
    int best = 1, best_padded = lanesFor(1).padded_disps;
    for (int pixels = 2; pixels <= sg; pixels *= 2) {
      const LanePlan lanes = lanesFor(pixels);
      if (lanes.lane_disps > 32) continue;
      const bool small = lanes.lane_disps <= 16;
      if (lanes.padded_disps < best_padded || (lanes.padded_disps == best_padded && small)) {
        best = pixels;
        best_padded = lanes.padded_disps;
      }
    }
    plan.pixels_per_subgroup = best;
  }
  const int lanes_per_pixel = sg / plan.pixels_per_subgroup;
  plan.lanes = lanesFor(plan.pixels_per_subgroup);
  const int padded = plan.lanes.padded_disps;
  plan.sum_row_bytes = static_cast<uint64_t>(W) * padded * 2;
  plan.sum_bytes = plan.sum_row_bytes * H;
  const uint64_t max_range = limits.maxRange();
  if (plan.sum_bytes > limits.max_allocation_bytes || plan.sum_bytes / 16 > limits.max_texel_buffer_elements)
    throw std::invalid_argument("StereoMatcher: the sums of " + std::to_string(plan.sum_bytes >> 20) +
                                " MiB exceed one allocation of this device (reduce size or num_disparities)");
  plan.rows_per_chunk = static_cast<int>(max_range / plan.sum_row_bytes);
  plan.num_chunks = plan.rows_per_chunk < 1 ? kMaxChunks + 1 : (H + plan.rows_per_chunk - 1) / plan.rows_per_chunk;
  if (plan.num_chunks > kMaxChunks)
    throw std::invalid_argument("StereoMatcher: sums too large for " + std::to_string(kMaxChunks) +
                                " storage buffer ranges (reduce size or num_disparities)");
  plan.scratch_bytes = static_cast<uint64_t>(2 * 2 * 3) * W * padded;  // 2 passes x 2 rows x 3 paths
  if (plan.cost_volume) {
    plan.cost_row_bytes = static_cast<uint64_t>(W) * padded;
    plan.cost_rows_per_chunk = static_cast<int>(max_range / plan.cost_row_bytes);
    plan.cost_row_words = static_cast<int>(plan.cost_row_bytes / 4);
    plan.cost_lanes = {padded / sg, padded};
  }
  // Loop iterations per walk of pixels_per_subgroup rows: the columns, the group's lag, the right map's borders.
  const int G = plan.pixels_per_subgroup;
  const int walk_cost =
      W + 2 * (G - 1) + 4 + (std::abs(params.min_disparity) + params.num_disparities) / lanes_per_pixel;
  plan.rows_per_dispatch = G * std::max(1, kMaxLoopIterations / walk_cost);
  return plan;
}

}  // namespace

DeviceLimits DeviceLimits::of(const VulkanContext& ctx) {
  DeviceLimits l;
  l.subgroup_size = ctx.subgroupSize();
  l.max_storage_buffer_range = ctx.maxStorageBufferRange();
  l.max_allocation_bytes = ctx.maxAllocationBytes();
  l.max_texel_buffer_elements = ctx.maxTexelBufferElements();
  l.cpu = ctx.info().type == "cpu";
  l.row_layout = ctx.supportsRowLayout();
  return l;
}

uint64_t DeviceLimits::maxRange() const { return std::min<uint64_t>(max_storage_buffer_range, 1ull << 31); }

LanePlan planLanes(int num_disparities, uint32_t subgroup_size, int multiple) {
  const int sg = static_cast<int>(subgroup_size);
  LanePlan plan;
  plan.lane_disps = (num_disparities + sg - 1) / sg;
  plan.lane_disps = (plan.lane_disps + multiple - 1) / multiple * multiple;
  plan.padded_disps = plan.lane_disps * sg;
  return plan;
}

std::vector<ChunkRange> rowRanges(uint64_t row_bytes, int rows, int rows_per_chunk) {
  const int count = (rows + rows_per_chunk - 1) / rows_per_chunk;
  std::vector<ChunkRange> ranges;
  for (int i = 0; i < kMaxChunks; ++i) {
    const uint64_t first_row = static_cast<uint64_t>(std::min(i, count - 1)) * rows_per_chunk;
    const uint64_t rows_here = std::min<uint64_t>(rows_per_chunk, rows - first_row);
    ranges.push_back({first_row * row_bytes, rows_here * row_bytes});
  }
  return ranges;
}

LayoutPlan planLayout(cv::Size size, const SgmParams& params, const DeviceLimits& limits) {
  params.validate();
  if (size.width < 1 || size.height < 1) throw std::invalid_argument("StereoMatcher: empty image size");
  if (size.width > kMaxWidth) throw std::invalid_argument("StereoMatcher: width above 4096");
  if (params.aggregation == Aggregation::rows && !limits.row_layout)
    throw std::invalid_argument(
        "StereoMatcher: aggregation 'rows' needs shaderInt64 and "
        "shaderStorageImageExtendedFormats, which this device lacks");
  LayoutPlan plan;
  plan.rows = params.aggregation == Aggregation::rows ||
              (params.aggregation == Aggregation::automatic && limits.cpu && limits.row_layout);
  if (plan.rows)
    plan.row_passes = planRows(size, params, limits);
  else
    plan.lines = planLines(size, params, limits);
  return plan;
}

}  // namespace e3d
}  // namespace ips
