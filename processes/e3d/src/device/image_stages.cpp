// The image stages (census, median, left-right check, fill, rectification, pyramid) and the Mutual Information
// stages (histogram, table).
#include "device/stages.hpp"

namespace ips {
namespace e3d {

namespace {

// census5x5 and median3x3: one invocation per column strip of E3D_STRIP rows, both images or maps (z).
void recordStrips(VkCommandBuffer cmd, const vk::Pipeline& pipeline, cv::Size size) {
  pipeline.bind(cmd);
  pipeline.push(cmd, shader::ImageParams{size.width, size.height});
  vkCmdDispatch(cmd, vk::groups(size.width, E3D_GROUP_SIZE), vk::groups(size.height, E3D_STRIP), 2);
  vk::computeBarrier(cmd);
}

}  // namespace

CensusStage::CensusStage(const vk::DescriptorPool& pool, cv::Size size, const vk::BufferView (&image_words)[2],
                         const vk::Buffer (&census)[2])
    : pipeline_(pool, "census5x5", {{0, image_words[0]}, {1, image_words[1]}, {2, census[0]}, {3, census[1]}},
                sizeof(shader::ImageParams)),
      size_(size) {}

void CensusStage::record(VkCommandBuffer cmd) const { recordStrips(cmd, pipeline_, size_); }

MedianStage::MedianStage(const vk::DescriptorPool& pool, cv::Size size, const vk::BufferView (&maps)[2],
                         const vk::Buffer (&out)[2])
    : pipeline_(pool, "median3x3", {{0, maps[0]}, {1, maps[1]}, {2, out[0]}, {3, out[1]}}, sizeof(shader::ImageParams)),
      size_(size) {}

void MedianStage::record(VkCommandBuffer cmd) const { recordStrips(cmd, pipeline_, size_); }

LrCheckStage::LrCheckStage(const vk::DescriptorPool& pool, cv::Size size, const vk::Buffer& left,
                           const vk::Buffer& right, const vk::Buffer& out, int max_diff)
    : pipeline_(pool, "lr_check", {{0, left}, {1, right}, {2, out}}, sizeof(shader::LrCheckParams)),
      pc_{size.width, size.height, max_diff * kSubpixelScale} {}

void LrCheckStage::record(VkCommandBuffer cmd) const {
  pipeline_.bind(cmd);
  pipeline_.push(cmd, pc_);
  vkCmdDispatch(cmd, vk::groups(pc_.width, E3D_LR_GROUP_X), vk::groups(pc_.height, E3D_LR_GROUP_Y), 1);
  vk::computeBarrier(cmd);
}

FillStage::FillStage(const vk::DescriptorPool& pool, cv::Size size, const vk::Buffer& in, const vk::Buffer& out)
    : pipeline_(pool, "fill_invalid", {{0, in}, {1, out}}, sizeof(shader::ImageParams)), size_(size) {}

void FillStage::record(VkCommandBuffer cmd) const {
  pipeline_.bind(cmd);
  pipeline_.push(cmd, shader::ImageParams{size_.width, size_.height});
  vkCmdDispatch(cmd, vk::groups(size_.height, E3D_GROUP_SIZE), 1, 1);
}

RectifyStage::RectifyStage(const vk::DescriptorPool& pool, cv::Size size, cv::Size raw_size, const vk::Buffer (&raw)[2],
                           const vk::Buffer& maps, const vk::Buffer (&out)[2])
    : pipeline_(pool, "rectify", {{0, raw[0]}, {1, raw[1]}, {2, maps}, {3, out[0]}, {4, out[1]}},
                sizeof(shader::RectifyParams)),
      pc_{size.width, size.height, raw_size.width, raw_size.height} {}

void RectifyStage::record(VkCommandBuffer cmd) const {
  pipeline_.bind(cmd);
  pipeline_.push(cmd, pc_);
  vkCmdDispatch(cmd, vk::groups((pc_.width * pc_.height + 3) / 4, E3D_GROUP_SIZE), 1, 2);  // 4 pixels each
  vk::computeBarrier(cmd);
}

DownsampleStage::DownsampleStage(const vk::DescriptorPool& pool, cv::Size source_size, cv::Size size,
                                 const vk::BufferView (&source_words)[2], const vk::Buffer (&out)[2])
    : pipeline_(pool, "downsample", {{0, source_words[0]}, {1, source_words[1]}, {2, out[0]}, {3, out[1]}},
                sizeof(shader::DownsampleParams)),
      pc_{source_size.width, source_size.height, size.width, size.height},
      size_(size) {}

void DownsampleStage::record(VkCommandBuffer cmd) const {
  pipeline_.bind(cmd);
  pipeline_.push(cmd, pc_);
  vkCmdDispatch(cmd, vk::groups((size_.area() + 3) / 4, E3D_GROUP_SIZE), 1, 2);  // 4 pixels each
  vk::computeBarrier(cmd);
}

MiHistogramStage::MiHistogramStage(const vk::DescriptorPool& pool, cv::Size size, cv::Size guide_size,
                                   const vk::BufferView (&image_words)[2], const vk::Buffer& guide,
                                   const vk::Buffer& histogram, const SgmParams& params)
    : pipeline_(pool, "mi_histogram", {{0, image_words[0]}, {1, image_words[1]}, {2, guide}, {3, histogram}},
                sizeof(shader::MiHistogramParams)),
      histogram_(histogram),
      pc_{size.width,
          size.height,
          guide_size.width,
          guide_size.height,
          0,
          params.min_disparity,
          params.num_disparities,
          params.mi_region_columns,
          params.mi_region_rows} {}

void MiHistogramStage::record(VkCommandBuffer cmd, Guide guide) const {
  vk::fillZero(cmd, histogram_);
  pipeline_.bind(cmd);
  shader::MiHistogramParams pc = pc_;
  pc.mode = static_cast<int>(guide);
  pipeline_.push(cmd, pc);
  vkCmdDispatch(cmd, vk::groups(pc.width, E3D_GROUP_SIZE), static_cast<uint32_t>(pc.height), 1);
  vk::computeBarrier(cmd);
}

MiTableStage::MiTableStage(const vk::DescriptorPool& pool, const vk::Buffer& histogram,
                           const vk::Buffer& log2_fractions, const vk::Buffer& work64, const vk::Buffer& work32,
                           const vk::Buffer& table, int regions)
    : regions_(regions) {
  for (int step = 0; step < E3D_MI_TABLE_STEPS; ++step)
    steps_[step] = vk::Pipeline(
        pool, "mi_table",
        {{0, histogram}, vk::Binding::uniformBuffer(1, log2_fractions), {2, work64}, {3, work32}, {4, table}}, 0,
        {{E3D_SPEC_MI_TABLE_STEP, step}});
}

void MiTableStage::record(VkCommandBuffer cmd) const {
  for (const vk::Pipeline& step : steps_) {
    step.bind(cmd);
    vkCmdDispatch(cmd, 256 / E3D_MI_TABLE_GROUP, static_cast<uint32_t>(regions_), 1);
    vk::computeBarrier(cmd);
  }
}

}  // namespace e3d
}  // namespace ips
