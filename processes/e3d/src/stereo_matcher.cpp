// StereoMatcher: the levels of the match (device/match_level.hpp), the optional rectification, and one command
// buffer per match holding everything from the upload to the maps the host reads back.
#include "ips/e3d/stereo_matcher.hpp"

#include <chrono>
#include <cstring>
#include <stdexcept>

#include "device/match_level.hpp"

namespace ips {
namespace e3d {

struct StereoMatcher::Impl {
  const VulkanContext& ctx;
  SgmParams params;
  // levels[0]: full resolution; for the Mutual Information hierarchy levels[l] at 1/2^l of it, each with the
  // level's search range and no fill, reading the images of levels[l - 1] and learning from levels[l + 1].
  std::vector<std::unique_ptr<MatchLevel>> levels;
  vk::CommandBuffer cmd;
  // Rectification (setRectification): the raw pair, the maps, and the stage writing levels[0]'s images.
  vk::DescriptorPool rect_pool;
  vk::Buffer raw[2], maps;
  std::optional<RectifyStage> rectify;
  bool flat_field = false;  // the maps buffer holds the rectification's gains, not ones
  cv::Size raw_size;
  size_t rect_bytes = 0;

  Impl(const VulkanContext& c, cv::Size size, const SgmParams& p) : ctx(c), params(p), cmd(c) {
    params.validate();
    if (params.search == Search::narrowed)
      throw std::invalid_argument(
          "StereoMatcher: search narrowed runs on the CPU reference only (sgmReference) so far; the device "
          "matches the full range");
    // A range no pixel of this width can have matches nothing: said, not a map without a single disparity.
    if (params.min_disparity >= size.width || params.min_disparity + params.num_disparities <= -size.width)
      throw std::invalid_argument("the disparity range [" + std::to_string(params.min_disparity) + ", " +
                                  std::to_string(params.min_disparity + params.num_disparities) +
                                  ") has no match in an image " + std::to_string(size.width) + " px wide");
    const bool hierarchy = params.cost == Cost::mi && params.mi_levels > 1;
    std::vector<cv::Size> sizes{size};
    for (int l = 1; hierarchy && l < params.mi_levels; ++l)
      sizes.push_back(cv::Size((sizes.back().width + 1) / 2, (sizes.back().height + 1) / 2));
    for (size_t l = 0; l < sizes.size(); ++l) {
      SgmParams lp = params.cost == Cost::mi ? miLevelParams(params, static_cast<int>(l), sizes[l]) : params;
      if (l > 0) {
        lp.mi_levels = 1;
        lp.fill_invalid = false;
      }
      const cv::Size below = l + 1 < sizes.size() ? sizes[l + 1] : cv::Size();
      levels.push_back(std::make_unique<MatchLevel>(ctx, sizes[l], lp, below));
      if (l > 0) levels[l]->readImagesFrom(*levels[l - 1]);
    }
    for (size_t l = 0; l + 1 < levels.size(); ++l) levels[l]->learnFrom(*levels[l + 1]);
  }

  ~Impl() { vkDeviceWaitIdle(ctx.device()); }

  MatchLevel& top() { return *levels.front(); }

  // The Mutual Information hierarchy: the pyramid, the coarsest level from the start disparity
  // (mi_coarse_iterations times, each learning from the one before), each finer level from the level below, and
  // the full resolution last.
  void recordHierarchy(const Timestamp& timestamp) {
    using Guide = MiHistogramStage::Guide;
    VkCommandBuffer c = cmd.handle();
    const int coarsest = static_cast<int>(levels.size()) - 1;
    for (int l = 1; l <= coarsest; ++l) levels[l]->recordDownsample(c);
    if (coarsest > 0) timestamp("pyramid");
    const Timestamp none = [](const char*) {};
    for (int l = coarsest; l >= 0; --l) {
      const MatchLevel& level = *levels[l];
      const int iterations = l == coarsest ? params.mi_coarse_iterations : 1;
      for (int it = 0; it < iterations; ++it) {
        level.recordMiTable(c, l < coarsest ? Guide::below : (it == 0 ? Guide::start : Guide::own));
        if (l == 0) timestamp("mi_table");
        level.recordMatching(c, l == 0 ? timestamp : none);
      }
      if (l > 0) timestamp(("mi_level" + std::to_string(l)).c_str());
    }
  }

  MatchOutput run(bool rectify_first, bool want_right) {
    const auto t0 = std::chrono::steady_clock::now();
    cmd.begin();
    const Timestamp timestamp = [this](const char* name) { cmd.timestamp(name); };
    cmd.timestamp(nullptr);
    if (rectify_first) {
      rectify->record(cmd.handle());
      timestamp("rectify");
    }
    if (params.cost == Cost::mi)
      recordHierarchy(timestamp);
    else
      top().recordMatching(cmd.handle(), timestamp);
    if (params.fill_invalid) {
      top().recordFill(cmd.handle());
      timestamp("fill");
    }
    cmd.submitAndWait();

    MatchOutput out;
    for (const auto& [name, ms] : cmd.stageTimes()) {
      out.stages.push_back({name, ms});
      out.device_ms += ms;
    }
    out.disparity = toInt16(params.fill_invalid ? top().filledLeft() : top().checkedLeft());
    if (want_right) out.right = toInt16(top().rightMap());
    out.total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  cv::Mat toInt16(const vk::Buffer& b) const {
    cv::Mat out;
    cv::Mat(levels.front()->size(), CV_32S, b.mapped()).convertTo(out, CV_16S);
    return out;
  }

  static void upload(const vk::Buffer& b, const cv::Mat& img) {
    auto* dst = static_cast<uint8_t*>(b.mapped());
    for (int y = 0; y < img.rows; ++y) std::memcpy(dst + static_cast<size_t>(y) * img.cols, img.ptr(y), img.cols);
  }

  static void checkPair(const cv::Mat& a, const cv::Mat& b, cv::Size expected, const char* what) {
    if (a.empty() || b.empty() || a.type() != CV_8UC1 || b.type() != CV_8UC1)
      throw std::invalid_argument(std::string("StereoMatcher: ") + what + " must be two CV_8UC1 images");
    if (a.size() != expected || b.size() != expected)
      throw std::invalid_argument(std::string("StereoMatcher: ") + what + " must be " + std::to_string(expected.width) +
                                  "x" + std::to_string(expected.height));
  }
};

StereoMatcher::StereoMatcher(VulkanContext& ctx, cv::Size size, const SgmParams& params)
    : impl_(new Impl(ctx, size, params)) {}

StereoMatcher::~StereoMatcher() = default;

MatchOutput StereoMatcher::match(const cv::Mat& left, const cv::Mat& right, bool want_right) {
  Impl::checkPair(left, right, size(), "match input");
  Impl::upload(impl_->top().images()[0], left);
  Impl::upload(impl_->top().images()[1], right);
  return impl_->run(false, want_right);
}

void StereoMatcher::setRectification(const StereoRectification& rect, cv::Size raw_size) {
  Impl& m = *impl_;
  const cv::Size rect_size = size();
  if (rect.size != rect_size) throw std::invalid_argument("StereoMatcher::setRectification: rectified size differs");
  const cv::Mat* maps[4] = {&rect.map0x, &rect.map0y, &rect.map1x, &rect.map1y};
  for (const cv::Mat* mp : maps)
    if (mp->type() != CV_32FC1 || mp->size() != rect_size)
      throw std::invalid_argument("StereoMatcher::setRectification: maps must be CV_32FC1 of the rectified size");
  if (rect.hasFlatField())
    for (const cv::Mat* gain : {&rect.gain0, &rect.gain1})
      if (gain->type() != CV_32FC1 || gain->size() != rect_size)
        throw std::invalid_argument("StereoMatcher::setRectification: gains must be CV_32FC1 of the rectified size");
  if (raw_size.width < 1 || raw_size.height < 1) throw std::invalid_argument("setRectification: empty raw size");
  vkDeviceWaitIdle(m.ctx.device());
  m.rectify.reset();
  m.rect_pool = vk::DescriptorPool(m.ctx, 1, 5, 0, 0);
  m.rect_bytes = 0;
  const size_t raw_pixels = static_cast<size_t>(raw_size.area());
  const size_t n = static_cast<size_t>(rect_size.area());
  for (auto& r : m.raw) r = vk::Buffer(m.ctx, (raw_pixels + 3) / 4 * 4, true, &m.rect_bytes);
  // The four maps, then both cameras' flat-field gains (1 without them: the stage multiplies always). Census
  // takes no flat field: it compares greys within 5x5 windows, whose order a smooth gain does not change, while the
  // gain lifts bright corners past 255 (the simulated hard walk: census 14.2 % bad without, 15.3 % with; MI 28.9 %
  // without, 12.4 % with).
  m.flat_field = rect.hasFlatField() && m.params.cost != Cost::census;
  m.maps = vk::Buffer(m.ctx, 6 * n * sizeof(float), true, &m.rect_bytes);
  for (int i = 0; i < 6; ++i) {
    cv::Mat dst(rect_size, CV_32F, static_cast<float*>(m.maps.mapped()) + i * n);
    if (i < 4)
      maps[i]->copyTo(dst);
    else if (m.flat_field)
      (i == 4 ? rect.gain0 : rect.gain1).copyTo(dst);
    else
      dst.setTo(1.0f);
  }
  m.raw_size = raw_size;
  m.rectify.emplace(m.rect_pool, rect_size, raw_size, m.raw, m.maps, m.top().images());
}

MatchOutput StereoMatcher::matchRaw(const cv::Mat& raw0, const cv::Mat& raw1, cv::Mat* rect0, cv::Mat* rect1,
                                    bool want_right) {
  if (!impl_->rectify) throw std::logic_error("StereoMatcher::matchRaw: call setRectification first");
  Impl::checkPair(raw0, raw1, impl_->raw_size, "matchRaw input");
  Impl::upload(impl_->raw[0], raw0);
  Impl::upload(impl_->raw[1], raw1);
  MatchOutput out = impl_->run(true, want_right);
  if (rect0) cv::Mat(size(), CV_8UC1, impl_->top().images()[0].mapped()).copyTo(*rect0);
  if (rect1) cv::Mat(size(), CV_8UC1, impl_->top().images()[1].mapped()).copyTo(*rect1);
  return out;
}

cv::Size StereoMatcher::size() const { return impl_->levels.front()->size(); }
const SgmParams& StereoMatcher::params() const { return impl_->params; }
bool StereoMatcher::appliesFlatField() const { return impl_->flat_field; }
std::string StereoMatcher::layoutDescription() const { return impl_->levels.front()->layoutDescription(); }
size_t StereoMatcher::deviceMemoryBytes() const {
  size_t bytes = impl_->rect_bytes;
  for (const auto& level : impl_->levels) bytes += level->memoryBytes();
  return bytes;
}

}  // namespace e3d
}  // namespace ips
