// E3D's device stages one at a time against the CPU reference of the same step (sgm.hpp, matching_cost.hpp,
// rectifyPair): each test uploads small inputs (random images from fixed seeds, odd sizes so that the four-pixel
// words, the strips and the subgroups end inside a row, plus an edge case), records that stage alone, and compares
// exactly. The end-to-end tests (test_e3d.cpp) say that the whole match agrees; these say which stage does not.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "device/layout_plan.hpp"
#include "device/stages.hpp"
#include "device/vk_objects.hpp"
#include "ips/calibration.hpp"
#include "ips/e3d/matching_cost.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/vulkan_context.hpp"

using namespace ips;
using namespace ips::e3d;

namespace {

VulkanContext& context() {
  static VulkanContext ctx;
  return ctx;
}

// Room for the descriptor sets of a few stages, path-cost chunk arrays included.
vk::DescriptorPool makePool() { return vk::DescriptorPool(context(), 8, 8 * kMaxChunks + 32, 32, 4); }

// Records what `record` records into a fresh command buffer, submits it and waits (the results are then visible
// in the host-visible buffers).
void runOnDevice(const std::function<void(VkCommandBuffer)>& record) {
  vk::CommandBuffer cmd(context());
  cmd.begin();
  record(cmd.handle());
  cmd.submitAndWait();
}

// A host-visible buffer of `bytes`, every byte `fill` (a value no stage writes where it must write, so that a
// missed element shows).
vk::Buffer hostBuffer(size_t bytes, uint8_t fill = 0xCD) {
  vk::Buffer b(context(), bytes, true);
  std::memset(b.mapped(), fill, b.size());
  return b;
}

// An 8-bit image as the stages read it: row-major without padding, four pixels to a 32-bit word.
vk::Buffer imageBuffer(const cv::Mat& image) {
  vk::Buffer b = hostBuffer((image.total() + 3) / 4 * 4, 0);
  for (int y = 0; y < image.rows; ++y)
    std::memcpy(static_cast<uint8_t*>(b.mapped()) + static_cast<size_t>(y) * image.cols, image.ptr(y), image.cols);
  return b;
}

cv::Mat readImage(const vk::Buffer& b, cv::Size size) { return cv::Mat(size, CV_8UC1, b.mapped()).clone(); }

// A CV_16S map as the stages hold maps: 32-bit integers.
vk::Buffer mapBuffer(const cv::Mat& map16) {
  vk::Buffer b = hostBuffer(map16.total() * 4);
  cv::Mat wrapped(map16.size(), CV_32S, b.mapped());
  map16.convertTo(wrapped, CV_32S);
  return b;
}

// A stage's map as it is (CV_32S, not saturated to 16 bits, so that an out-of-range value shows).
cv::Mat readMap(const vk::Buffer& b, cv::Size size) { return cv::Mat(size, CV_32S, b.mapped()).clone(); }

// Pixels where the two maps differ; `reference` is converted to the type of `device`.
int differences(const cv::Mat& device, const cv::Mat& reference) {
  cv::Mat ref;
  reference.convertTo(ref, device.type());
  cv::Mat diff;
  cv::compare(device, ref, diff, cv::CMP_NE);
  return cv::countNonZero(diff);
}

cv::Mat randomImage(cv::Size size, uint64_t seed, int lo = 0, int hi = 256) {
  cv::Mat image(size, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, lo, hi);
  return image;
}

// A CV_16S map of disparities x 16 in [lo16, hi16) with about `invalid_percent` % of the pixels invalid.
cv::Mat randomMap(cv::Size size, uint64_t seed, int lo16, int hi16, int invalid_percent) {
  cv::Mat map(size, CV_16S);
  cv::RNG rng(seed);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      map.at<int16_t>(y, x) =
          rng.uniform(0, 100) < invalid_percent ? kInvalidDisparity : static_cast<int16_t>(rng.uniform(lo16, hi16));
  return map;
}

// The pair the stages of both images read: the buffers and their views as 32-bit words.
struct ImagePair {
  vk::Buffer buffers[2];
  vk::BufferView words[2];
  ImagePair(const cv::Mat& left, const cv::Mat& right)
      : buffers{imageBuffer(left), imageBuffer(right)},
        words{vk::BufferView(context().device(), buffers[0], VK_FORMAT_R32_UINT),
              vk::BufferView(context().device(), buffers[1], VK_FORMAT_R32_UINT)} {}
};

// Rows of the path-cost volume (lines) or of a cost volume, split over buffers of rows_per_chunk rows as the
// matcher splits them, seen by the shaders through kMaxChunks descriptors (the last one repeated).
class Volume {
 public:
  Volume(int rows, uint64_t row_bytes, int rows_per_chunk) : row_bytes_(row_bytes), rows_per_chunk_(rows_per_chunk) {
    for (int first = 0; first < rows; first += rows_per_chunk)
      buffers_.push_back(hostBuffer(static_cast<size_t>(std::min(rows_per_chunk, rows - first)) * row_bytes));
  }
  uint8_t* row(int g) const {
    const int chunk = g / rows_per_chunk_;
    return static_cast<uint8_t*>(buffers_[chunk].mapped()) + (g - chunk * rows_per_chunk_) * row_bytes_;
  }
  std::vector<vk::Descriptor> descriptors() const {
    std::vector<vk::Descriptor> d;
    for (int i = 0; i < kMaxChunks; ++i) d.push_back({buffers_[std::min<size_t>(i, buffers_.size() - 1)].handle()});
    return d;
  }
  size_t chunks() const { return buffers_.size(); }
  const vk::Buffer& buffer(size_t chunk) const { return buffers_[chunk]; }

 private:
  std::vector<vk::Buffer> buffers_;
  uint64_t row_bytes_;
  int rows_per_chunk_;
};

// The byte of disparity index k of pixel x in a volume row: each lane owns K consecutive disparities, the lanes of a
// pixel one after the other, so pixel x's padded range lies at bytes x * padded_disps onwards, in order.
size_t laneByte(int x, int k, const LanePlan& lanes) { return static_cast<size_t>(x) * lanes.padded_disps + k; }

// Slice rows base_row .. base_row + H - 1 of a volume as [y][x][k] (k < num_disparities), the layout of
// costVolume and aggregateCosts; `padding` counts the padded disparities' bytes that are not 255.
std::vector<uint8_t> readSlice(const Volume& v, int base_row, cv::Size size, int num_disparities, const LanePlan& lanes,
                               int* padding = nullptr) {
  std::vector<uint8_t> out(size.area() * static_cast<size_t>(num_disparities));
  if (padding) *padding = 0;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      for (int k = 0; k < lanes.padded_disps; ++k) {
        const uint8_t value = v.row(base_row + y)[laneByte(x, k, lanes)];
        if (k < num_disparities)
          out[(static_cast<size_t>(y) * size.width + x) * num_disparities + k] = value;
        else if (padding)
          *padding += value != 255;
      }
  return out;
}

// Writes [y][x][k] costs into slice rows base_row .. base_row + H - 1, the padded disparities costing 255.
void writeSlice(const Volume& v, int base_row, cv::Size size, int num_disparities, const LanePlan& lanes,
                const std::vector<uint8_t>& costs) {
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      for (int k = 0; k < lanes.padded_disps; ++k)
        v.row(base_row + y)[laneByte(x, k, lanes)] =
            k < num_disparities ? costs[(static_cast<size_t>(y) * size.width + x) * num_disparities + k] : 255;
}

int mismatches(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  int n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += a[i] != b[i];
  return n;
}

// The lines layout of a match of `size` on this device, with storage-buffer ranges of `rows_per_range` volume rows at
// most, so that the volume is split over several buffers as in a large match.
LinesPlan linesPlan(cv::Size size, SgmParams params, int rows_per_range) {
  DeviceLimits limits = DeviceLimits::of(context());
  const LanePlan lanes = planLanes(params.num_disparities, limits.subgroup_size, 4);
  limits.max_storage_buffer_range = static_cast<uint64_t>(size.width) * lanes.padded_disps * rows_per_range;
  params.aggregation = Aggregation::lines;
  return planLayout(size, params, limits).lines;
}

// The specialisation of the lines layout's match stages for the first match or (mirror) the second, right to left.
vk::Specialisation specialisation(int lane_disps, const SgmParams& params, bool mirror = false) {
  return matchSpecialisation(context().subgroupSize(), lane_disps, params, {0, mirror, !mirror, false});
}

// ---- census5x5 ----

void expectCensusEqualsReference(const cv::Mat& left, const cv::Mat& right) {
  const size_t pixels = left.total();
  ImagePair images(left, right);
  vk::Buffer census[2] = {hostBuffer(pixels * 4), hostBuffer(pixels * 4)};
  vk::DescriptorPool pool = makePool();
  CensusStage stage(pool, left.size(), images.words, census);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  EXPECT_EQ(differences(readMap(census[0], left.size()), census5x5(left)), 0) << left.size();
  EXPECT_EQ(differences(readMap(census[1], left.size()), census5x5(right)), 0) << left.size();
}

TEST(CensusStage, EqualsReferenceOnRandomImagesOfOddSizes) {
  expectCensusEqualsReference(randomImage({37, 23}, 1), randomImage({37, 23}, 2));
  // Smaller than the window and than one strip of rows.
  expectCensusEqualsReference(randomImage({3, 5}, 3), randomImage({3, 5}, 4));
  // Few grey levels: many neighbours equal to the centre, which set no bit.
  expectCensusEqualsReference(randomImage({29, 17}, 5, 0, 3), randomImage({29, 17}, 6, 0, 3));
}

TEST(CensusStage, ConstantImageGivesZeroCodes) {
  const cv::Mat flat(23, 37, CV_8UC1, cv::Scalar(77));
  ASSERT_EQ(cv::countNonZero(census5x5(flat)), 0);
  expectCensusEqualsReference(flat, randomImage(flat.size(), 7));
}

// ---- median3x3 ----

void expectMedianEqualsReference(const cv::Mat& left16, const cv::Mat& right16) {
  const cv::Size size = left16.size();
  vk::Buffer maps[2] = {mapBuffer(left16), mapBuffer(right16)};
  const vk::BufferView texels[2] = {vk::BufferView(context().device(), maps[0], VK_FORMAT_R32_SINT),
                                    vk::BufferView(context().device(), maps[1], VK_FORMAT_R32_SINT)};
  vk::Buffer out[2] = {hostBuffer(size.area() * 4), hostBuffer(size.area() * 4)};
  vk::DescriptorPool pool = makePool();
  MedianStage stage(pool, size, texels, out);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  EXPECT_EQ(differences(readMap(out[0], size), median3x3(left16)), 0) << size;
  EXPECT_EQ(differences(readMap(out[1], size), median3x3(right16)), 0) << size;
}

TEST(MedianStage, EqualsReferenceOnRandomMapsWithInvalidPixels) {
  const cv::Size size(37, 23);
  // Negative disparities too; invalid pixels take part in the median with their (smallest) value.
  expectMedianEqualsReference(randomMap(size, 11, -40, 900, 20), randomMap(size, 12, -40, 900, 45));
  expectMedianEqualsReference(randomMap({2, 11}, 13, 0, 300, 10), randomMap({2, 11}, 14, 0, 300, 10));
}

TEST(MedianStage, AllInvalidMapStaysInvalid) {
  const cv::Size size(37, 23);
  const cv::Mat invalid(size, CV_16S, cv::Scalar(kInvalidDisparity));
  expectMedianEqualsReference(invalid, randomMap(size, 15, 0, 64, 90));
}

// ---- lr_check ----

void expectLrCheckEqualsReference(const cv::Mat& left16, const cv::Mat& right16, int max_diff) {
  const cv::Size size = left16.size();
  vk::Buffer left = mapBuffer(left16), right = mapBuffer(right16), out = hostBuffer(size.area() * 4);
  vk::DescriptorPool pool = makePool();
  LrCheckStage stage(pool, size, left, right, out, max_diff);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  cv::Mat expected = left16.clone();
  leftRightCheck(expected, right16, max_diff);
  EXPECT_EQ(differences(readMap(out, size), expected), 0) << size << " max_diff " << max_diff;
}

TEST(LrCheckStage, EqualsReferenceOnRandomMaps) {
  const cv::Size size(37, 23);
  // Left disparities from -2 to 12 px (some point outside the row); the right map where they point holds the same
  // disparity (a third of them) or one up to 3 px off, so that each tolerance keeps some pixels and rejects some.
  const cv::Mat left = randomMap(size, 21, -2 * 16, 12 * 16, 15);
  cv::Mat right = randomMap(size, 22, -2 * 16, 12 * 16, 15);
  cv::RNG rng(23);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const int d = left.at<int16_t>(y, x), xr = x - (d + 8) / 16;
      if (d != kInvalidDisparity && xr >= 0 && xr < size.width && rng.uniform(0, 10) > 0)
        right.at<int16_t>(y, xr) = static_cast<int16_t>(d + (rng.uniform(0, 3) == 0 ? 0 : rng.uniform(-48, 49)));
    }
  for (int max_diff : {0, 1, 2}) {
    cv::Mat checked = left.clone();
    leftRightCheck(checked, right, max_diff);
    // Not vacuous: the check keeps some pixels and removes some.
    EXPECT_GT(cv::countNonZero(checked != kInvalidDisparity), 20);
    EXPECT_GT(cv::countNonZero(checked != left), 20);
    expectLrCheckEqualsReference(left, right, max_diff);
  }
}

TEST(LrCheckStage, AllInvalidRightMapInvalidatesEverything) {
  const cv::Size size(37, 23);
  const cv::Mat invalid(size, CV_16S, cv::Scalar(kInvalidDisparity));
  expectLrCheckEqualsReference(randomMap(size, 23, 0, 16 * 16, 0), invalid, 2);
  expectLrCheckEqualsReference(invalid, randomMap(size, 24, 0, 16 * 16, 0), 2);
}

// ---- fill_invalid ----

void expectFillEqualsReference(const cv::Mat& map16) {
  const cv::Size size = map16.size();
  vk::Buffer in = mapBuffer(map16), out = hostBuffer(size.area() * 4);
  vk::DescriptorPool pool = makePool();
  FillStage stage(pool, size, in, out);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  cv::Mat expected = map16.clone();
  fillInvalid(expected);
  EXPECT_EQ(differences(readMap(out, size), expected), 0) << size;
}

TEST(FillStage, EqualsReferenceOnRandomMaps) {
  const cv::Size size(37, 23);
  cv::Mat map = randomMap(size, 31, 0, 40 * 16, 60);
  map.row(4).setTo(kInvalidDisparity);  // a row without any valid pixel stays invalid
  map.col(0).setTo(kInvalidDisparity);  // invalid at the row ends: one neighbour only
  map.col(size.width - 1).setTo(kInvalidDisparity);
  expectFillEqualsReference(map);
  expectFillEqualsReference(randomMap(size, 32, -100, 100, 95));
  expectFillEqualsReference(randomMap(size, 33, 0, 500, 0));  // nothing to fill
}

TEST(FillStage, AllInvalidMapStaysInvalid) {
  expectFillEqualsReference(cv::Mat(23, 37, CV_16S, cv::Scalar(kInvalidDisparity)));
}

// ---- rectify ----

// The device's rectification of random raw images with `rect`'s maps against rectifyPair (cv::remap, bilinear,
// border 0), exactly, half-way values included (both round them up); they are counted, so that the test shows it
// met some. The exact value is cv::remap's of the image as floats.
void expectRectifyEqualsReference(const StereoRectification& rect, cv::Size raw_size) {
  const cv::Mat raw[2] = {randomImage(raw_size, 41), randomImage(raw_size, 42)};
  const cv::Size size = rect.size;
  const size_t n = size.area();
  vk::Buffer raw_buffers[2] = {imageBuffer(raw[0]), imageBuffer(raw[1])};
  // The maps and the gains, as StereoMatcher::setRectification lays them out (gains 1 without a flat field).
  vk::Buffer maps = hostBuffer(6 * n * sizeof(float));
  const cv::Mat unit_gain(size, CV_32F, cv::Scalar(1.0f));
  const cv::Mat* planes[6] = {&rect.map0x,
                              &rect.map0y,
                              &rect.map1x,
                              &rect.map1y,
                              rect.hasFlatField() ? &rect.gain0 : &unit_gain,
                              rect.hasFlatField() ? &rect.gain1 : &unit_gain};
  for (int i = 0; i < 6; ++i) {
    cv::Mat plane(size, CV_32F, static_cast<float*>(maps.mapped()) + i * n);
    planes[i]->copyTo(plane);
  }
  vk::Buffer out[2] = {hostBuffer((n + 3) / 4 * 4), hostBuffer((n + 3) / 4 * 4)};
  vk::DescriptorPool pool = makePool();
  RectifyStage stage(pool, size, raw_size, raw_buffers, maps, out);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  cv::Mat cpu[2];
  rectifyPair(rect, raw[0], raw[1], cpu[0], cpu[1]);
  for (int cam = 0; cam < 2; ++cam) {
    cv::Mat raw_float, exact;
    raw[cam].convertTo(raw_float, CV_32F);
    cv::remap(raw_float, exact, *planes[2 * cam], *planes[2 * cam + 1], cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar(0));
    const cv::Mat device = readImage(out[cam], size);
    int different = 0, ties = 0;
    for (int i = 0; i < static_cast<int>(n); ++i) {
      const float v = exact.at<float>(i) * planes[4 + cam]->at<float>(i);
      ties += std::abs(v - std::floor(v) - 0.5f) < 1e-3f;
      different += device.at<uint8_t>(i) != cpu[cam].at<uint8_t>(i);
    }
    EXPECT_EQ(different, 0) << "camera " << cam << " " << size << " (half-way values: " << ties << ")";
  }
}

// Sample positions on cv::remap's grid of 1/32 px (INTER_TAB_SIZE), where its fixed-point weights are exact: there
// the device's float interpolation and cv::remap compute the same value. Positions reach past every border.
cv::Mat gridMap(cv::Size size, uint64_t seed, int raw_extent) {
  cv::Mat map(size, CV_32F);
  cv::RNG rng(seed);
  for (int i = 0; i < static_cast<int>(map.total()); ++i)
    map.at<float>(i) = rng.uniform(-2 * 32, (raw_extent + 1) * 32) / 32.0f;
  return map;
}

// Maps of 37x23 rectified pixels on cv::remap's grid into raw images of raw_size.
StereoRectification gridRectification(cv::Size raw_size) {
  StereoRectification rect;
  rect.size = cv::Size(37, 23);
  rect.map0x = gridMap(rect.size, 43, raw_size.width);
  rect.map0y = gridMap(rect.size, 44, raw_size.height);
  rect.map1x = gridMap(rect.size, 45, raw_size.width);
  rect.map1y = gridMap(rect.size, 46, raw_size.height);
  return rect;
}

TEST(RectifyStage, EqualsRemapOnItsSampleGrid) {
  const cv::Size raw_size(41, 29);
  expectRectifyEqualsReference(gridRectification(raw_size), raw_size);
}

TEST(RectifyStage, FlatFieldGainsEqualRemapTimesGain) {
  // Gains from 0.5 to 7 (the raw corners of the simulated head's 85 deg lenses need 6.8): each grey is the sample
  // times its gain, rounded half up, clamped to 255 where the gain lifts it past.
  const cv::Size raw_size(41, 29);
  StereoRectification rect = gridRectification(raw_size);
  for (cv::Mat* gain : {&rect.gain0, &rect.gain1}) {
    gain->create(rect.size, CV_32F);
    cv::randu(*gain, 0.5f, 7.0f);
  }
  expectRectifyEqualsReference(rect, raw_size);
  cv::Mat cpu[2];
  rectifyPair(rect, randomImage(raw_size, 41), randomImage(raw_size, 42), cpu[0], cpu[1]);
  EXPECT_GT(cv::countNonZero(cpu[0] == 255), 0) << "no grey lifted past 255: the clamp is not tested";
}

TEST(RectifyStage, IdentityAndOutsideMaps) {
  // Whole-pixel positions copy the raw image; positions wholly outside give the border 0.
  const cv::Size size(37, 23);
  StereoRectification rect;
  rect.size = size;
  rect.map0x.create(size, CV_32F);
  rect.map0y.create(size, CV_32F);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      rect.map0x.at<float>(y, x) = static_cast<float>(x);
      rect.map0y.at<float>(y, x) = static_cast<float>(y);
    }
  rect.map1x = cv::Mat(size, CV_32F, cv::Scalar(-5.0f));
  rect.map1y = cv::Mat(size, CV_32F, cv::Scalar(500.0f));
  expectRectifyEqualsReference(rect, size);
}

// ---- downsample ----

TEST(DownsampleStage, EqualsHalfSizeOnOddSizes) {
  for (cv::Size source : {cv::Size(37, 23), cv::Size(1, 1), cv::Size(6, 9)}) {
    const cv::Mat left = randomImage(source, 51), right(source, CV_8UC1, cv::Scalar(255));
    const cv::Size half((source.width + 1) / 2, (source.height + 1) / 2);
    ImagePair images(left, right);
    vk::Buffer out[2] = {hostBuffer((half.area() + 3) / 4 * 4), hostBuffer((half.area() + 3) / 4 * 4)};
    vk::DescriptorPool pool = makePool();
    DownsampleStage stage(pool, source, half, images.words, out);
    runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
    EXPECT_EQ(differences(readImage(out[0], half), halfSize(left)), 0) << source;
    EXPECT_EQ(differences(readImage(out[1], half), halfSize(right)), 0) << source;
  }
}

// ---- the cost stages ----

// cost_census into the cost slice of the lines layout (after the path slices), the volume split over buffers.
void expectCensusCostEqualsReference(const cv::Mat& left, const cv::Mat& right, const SgmParams& params) {
  const cv::Size size = left.size();
  const LinesPlan plan = linesPlan(size, params, 40);
  Volume volume((params.paths + 1) * size.height, plan.row_bytes, plan.rows_per_chunk);
  ASSERT_GT(volume.chunks(), 1u);
  vk::Buffer census[2] = {hostBuffer(size.area() * 4), hostBuffer(size.area() * 4)};
  const cv::Mat codes[2] = {census5x5(left), census5x5(right)};
  for (int i = 0; i < 2; ++i) std::memcpy(census[i].mapped(), codes[i].data, size.area() * 4);
  vk::DescriptorPool pool = makePool();
  CostStage stage = CostStage::census(pool, specialisation(plan.lanes.lane_disps, params), size, params, census[0],
                                      census[1], volume.descriptors(), plan);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  int padding = 0;
  const std::vector<uint8_t> device =
      readSlice(volume, plan.cost_base_row, size, params.num_disparities, plan.lanes, &padding);
  EXPECT_EQ(mismatches(device, costVolume(left, right, params)), 0) << params.describe();
  EXPECT_EQ(padding, 0);  // the padded disparities cost 255
}

TEST(CostStage, CensusEqualsReference) {
  const cv::Mat left = randomImage({37, 23}, 61), right = randomImage({37, 23}, 62);
  SgmParams p;
  p.num_disparities = 21;  // padded to whole lanes
  p.min_disparity = -3;
  expectCensusCostEqualsReference(left, right, p);
  p.num_disparities = 48;
  p.min_disparity = 30;  // most of the range beyond the row's start: clamped columns
  expectCensusCostEqualsReference(left, right, p);
  // Constant images: every cost 0.
  const cv::Mat flat(left.size(), CV_8UC1, cv::Scalar(9));
  expectCensusCostEqualsReference(flat, flat, p);
}

// The pair the second match sees, as the reference takes it: the right image mirrored as the left one and the left
// mirrored as the right one (new matrices: flipping into headers of the inputs would overwrite them).
std::pair<cv::Mat, cv::Mat> mirroredPair(const cv::Mat& left, const cv::Mat& right) {
  cv::Mat mirrored_left, mirrored_right;
  cv::flip(right, mirrored_left, 1);
  cv::flip(left, mirrored_right, 1);
  return {mirrored_left, mirrored_right};
}

// cost_ad, cost_sad, cost_mi into a cost volume of `lane_multiple` (4: the lines layout, 32-bit stores; 8: the
// rows layout, 64-bit stores) at base row 3, split over buffers of 5 rows; `mirror`: the second match, which reads
// the pair swapped and mirrored (and the tables transposed, their regions mirrored), i.e. the reference's mirrored
// pair. mi: `tables` holds one table per region of params' grid.
void expectIntensityCostEqualsReference(const cv::Mat& left, const cv::Mat& right, const SgmParams& params,
                                        int lane_multiple, bool mirror, const MiTables& tables = MiTables()) {
  const cv::Size size = left.size();
  const LanePlan lanes = planLanes(params.num_disparities, context().subgroupSize(), lane_multiple);
  const uint64_t row_bytes = static_cast<uint64_t>(size.width) * lanes.padded_disps;
  const int base_row = 3;
  Volume volume(base_row + size.height, row_bytes, 5);
  ImagePair images(left, right);
  vk::Buffer table_buffer = hostBuffer(std::max<size_t>(1, tables.tables.size()) * E3D_MI_TABLE_BYTES);
  for (size_t i = 0; i < tables.tables.size(); ++i)
    std::memcpy(static_cast<uint8_t*>(table_buffer.mapped()) + i * E3D_MI_TABLE_BYTES, tables.tables[i].data,
                E3D_MI_TABLE_BYTES);
  const int m = mirror ? 1 : 0;
  vk::DescriptorPool pool = makePool();
  CostStage stage = CostStage::intensity(pool, specialisation(lanes.lane_disps, params, mirror), size, params,
                                         images.words[m], images.words[1 - m], volume.descriptors(), &table_buffer,
                                         base_row, 5, static_cast<int>(row_bytes / 4));
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  auto [ref_left, ref_right] = mirror ? mirroredPair(left, right) : std::pair<cv::Mat, cv::Mat>(left, right);
  int padding = 0;
  const std::vector<uint8_t> device = readSlice(volume, base_row, size, params.num_disparities, lanes, &padding);
  EXPECT_EQ(mismatches(device, costVolume(ref_left, ref_right, params, mirror ? tables.swapped() : tables)), 0)
      << params.describe() << " lanes of " << lanes.lane_disps << (mirror ? " mirrored" : "");
  EXPECT_EQ(padding, 0);
  EXPECT_EQ(volume.row(0)[0], 0xCD);  // rows before base_row untouched
}

TEST(CostStage, AdAndSadEqualReference) {
  const cv::Mat left = randomImage({37, 23}, 63), right = randomImage({37, 23}, 64);
  for (Cost cost : {Cost::ad, Cost::sad}) {
    SgmParams p = SgmParams::forCost(cost);
    p.num_disparities = 19;
    p.min_disparity = -2;
    for (int multiple : {4, 8})
      for (bool mirror : {false, true}) expectIntensityCostEqualsReference(left, right, p, multiple, mirror);
    // Constant images: every cost 0; and a range reaching past the row: clamped columns.
    const cv::Mat flat(left.size(), CV_8UC1, cv::Scalar(200));
    expectIntensityCostEqualsReference(flat, flat, p, 8, false);
    p.num_disparities = 50;
    p.min_disparity = 20;
    expectIntensityCostEqualsReference(left, right, p, 4, false);
  }
}

// Random tables (the stage only looks costs up), one per region of params' grid.
MiTables randomTables(const SgmParams& params, uint64_t seed) {
  MiTables tables;
  tables.columns = params.mi_region_columns;
  tables.rows = params.mi_region_rows;
  for (int i = 0; i < tables.columns * tables.rows; ++i)
    tables.tables.push_back(randomImage({256, 256}, seed + i, 0, 64));
  return tables;
}

TEST(CostStage, MutualInformationEqualsReference) {
  const cv::Mat left = randomImage({37, 23}, 65), right = randomImage({37, 23}, 66);
  SgmParams p = SgmParams::forCost(Cost::mi);
  p.num_disparities = 27;
  p.min_disparity = 1;
  // One table; the default grid (6 x 3); a grid of regions of one and two columns and rows (37 / 7 = 5.3: uneven).
  for (cv::Size grid : {cv::Size(1, 1), cv::Size(p.mi_region_columns, p.mi_region_rows), cv::Size(7, 5)}) {
    p.mi_region_columns = grid.width;
    p.mi_region_rows = grid.height;
    const MiTables tables = randomTables(p, 67);
    for (int window : {1, 3}) {  // pixelwise, and the mean over 3x3
      p.mi_window = window;
      for (int multiple : {4, 8})
        for (bool mirror : {false, true}) expectIntensityCostEqualsReference(left, right, p, multiple, mirror, tables);
    }
  }
  // A range reaching past the row: the window's columns clamped on both images.
  p.num_disparities = 50;
  p.min_disparity = 20;
  expectIntensityCostEqualsReference(left, right, p, 4, false, randomTables(p, 68));
}

TEST(CostStage, MutualInformationRegionsReadTheirOwnTables) {
  // Each region's table a constant of its own: the cost of every pixel and disparity is its region's constant,
  // whatever the greys (the window's mean of a constant), so a region reading a neighbour's table shows.
  const cv::Mat left = randomImage({37, 23}, 69), right = randomImage({37, 23}, 70);
  SgmParams p = SgmParams::forCost(Cost::mi);
  p.num_disparities = 9;
  p.mi_region_columns = 4;
  p.mi_region_rows = 3;
  MiTables tables;
  tables.columns = 4;
  tables.rows = 3;
  for (int i = 0; i < 12; ++i) tables.tables.push_back(cv::Mat(256, 256, CV_8UC1, cv::Scalar(3 + 5 * i)));
  const std::vector<uint8_t> costs = costVolume(left, right, p, tables);
  for (int y : {0, 7, 8, 15, 16, 22})
    for (int x : {0, 9, 10, 18, 19, 27, 28, 36}) {
      const int region = miRegionOf(y, 3, 23) * 4 + miRegionOf(x, 4, 37);
      EXPECT_EQ(costs[(static_cast<size_t>(y) * 37 + x) * 9 + 4], 3 + 5 * region) << x << ", " << y;
    }
  EXPECT_EQ(miRegionOf(8, 4, 37), 0);  // region 1 starts at floor(37 / 4) = 9, region 3 at floor(3 * 37 / 4) = 27
  EXPECT_EQ(miRegionOf(9, 4, 37), 1);
  EXPECT_EQ(miRegionOf(26, 4, 37), 2);
  EXPECT_EQ(miRegionOf(27, 4, 37), 3);
  EXPECT_EQ(miRegionOf(36, 4, 37), 3);
  for (int multiple : {4, 8})
    for (bool mirror : {false, true}) expectIntensityCostEqualsReference(left, right, p, multiple, mirror, tables);
}

// A 37 x 23 pair whose left image is the right one shifted by `shift` px, with noise: the paths have a minimum to
// follow, as in a real match.
void shiftedPair(uint64_t seed, int shift, cv::Mat& left, cv::Mat& right) {
  right = randomImage({37, 23}, seed);
  left = right.clone();
  right.colRange(0, right.cols - shift).copyTo(left.colRange(shift, left.cols));
  left += randomImage(left.size(), seed + 1, 0, 20);
}

// ---- sgm_aggregate (lines) ----

// Costs of the reference in the cost slice, the aggregation alone, each path slice against pathCosts of its direction
// (aggregateCosts is their sum). `mirror`: the second match, right to left, whose image (the right one, read mirrored)
// sets the adaptive P2; its reference is the mirrored pair.
void expectLineAggregationEqualsReference(const cv::Mat& left, const cv::Mat& right, const SgmParams& params,
                                          bool mirror = false) {
  const cv::Size size = left.size();
  const LinesPlan plan = linesPlan(size, params, 11);
  Volume volume((params.paths + 1) * size.height, plan.row_bytes, plan.rows_per_chunk);
  const auto [ref_left, ref_right] = mirror ? mirroredPair(left, right) : std::pair<cv::Mat, cv::Mat>(left, right);
  const std::vector<uint8_t> costs = costVolume(ref_left, ref_right, params);
  writeSlice(volume, plan.cost_base_row, size, params.num_disparities, plan.lanes, costs);
  vk::Buffer image = imageBuffer(mirror ? right : left);
  vk::DescriptorPool pool = makePool();
  LineAggregationStage stage(pool, specialisation(plan.lanes.lane_disps, params, mirror), size, params, image,
                             volume.descriptors(), plan);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  // Each path's slice against that path alone, so that a wrong direction shows by name.
  for (int path = 0; path < params.paths; ++path) {
    const std::vector<uint8_t> slice = readSlice(volume, path * size.height, size, params.num_disparities, plan.lanes);
    const std::vector<uint16_t> expected = pathCosts(ref_left, costs, params, path);
    size_t different = 0;
    for (size_t i = 0; i < slice.size(); ++i) different += slice[i] != expected[i];
    EXPECT_EQ(different, 0u) << params.describe() << (mirror ? " mirrored" : "") << ", path " << path << " ("
                             << kPathDirections[path][0] << ", " << kPathDirections[path][1] << ")";
  }
}

TEST(LineAggregationStage, EqualsReference) {
  cv::Mat left, right;
  shiftedPair(71, 5, left, right);
  SgmParams p;
  p.num_disparities = 21;
  p.min_disparity = -2;
  expectLineAggregationEqualsReference(left, right, p);
  p.paths = 4;
  p.p2_slope = 0;  // constant P2
  expectLineAggregationEqualsReference(left, right, p);
  SgmParams ad = SgmParams::forCost(Cost::ad);  // costs up to 63 and the adaptive P2 of AD
  ad.num_disparities = 40;
  expectLineAggregationEqualsReference(left, right, ad);
  // Constant images: every cost 0, every path cost 0.
  const cv::Mat flat(left.size(), CV_8UC1, cv::Scalar(100));
  expectLineAggregationEqualsReference(flat, flat, p);
}

// The second match's aggregation: the adaptive P2 must follow the mirrored right image, not the left one.
TEST(LineAggregationStage, SecondMatchEqualsReferenceOfTheMirroredPair) {
  cv::Mat left, right;
  shiftedPair(72, 4, left, right);
  SgmParams p;
  p.num_disparities = 21;
  expectLineAggregationEqualsReference(left, right, p, true);
  SgmParams ad = SgmParams::forCost(Cost::ad);
  ad.num_disparities = 16;
  expectLineAggregationEqualsReference(left, right, ad, true);
}

// ---- sgm_wta (lines) ----

// Random path costs in the path slices, the winner-takes-all alone against winnerTakesAll of their sums. `mirror`:
// the second match, whose map is stored mirrored back (its columns run right to left) and which writes no right map.
void expectWtaEqualsReference(cv::Size size, const SgmParams& params, uint64_t seed, int max_path_cost,
                              bool mirror = false) {
  const LinesPlan plan = linesPlan(size, params, 13);
  Volume volume((params.paths + 1) * size.height, plan.row_bytes, plan.rows_per_chunk);
  const size_t n = size.area() * static_cast<size_t>(params.num_disparities);
  std::vector<uint16_t> sums(n, 0);
  cv::RNG rng(seed);
  for (int path = 0; path < params.paths; ++path) {
    std::vector<uint8_t> costs(n);
    for (size_t i = 0; i < n; ++i) {
      costs[i] = static_cast<uint8_t>(rng.uniform(0, max_path_cost + 1));
      sums[i] = static_cast<uint16_t>(sums[i] + costs[i]);
    }
    writeSlice(volume, path * size.height, size, params.num_disparities, plan.lanes, costs);
  }
  vk::Buffer disp[2] = {hostBuffer(size.area() * 4), hostBuffer(size.area() * 4)};
  vk::DescriptorPool pool = makePool();
  WtaStage stage(pool, specialisation(plan.lanes.lane_disps, params, mirror), size, params, volume.descriptors(),
                 disp[0], disp[1], plan);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  cv::Mat left16, right16;
  winnerTakesAll(sums, size, params, left16, right16);
  if (mirror) {
    cv::Mat stored;
    cv::flip(left16, stored, 1);
    EXPECT_EQ(differences(readMap(disp[0], size), stored), 0) << params.describe() << " mirrored";
    const cv::Mat untouched = readMap(disp[1], size) != static_cast<int32_t>(0xCDCDCDCD);
    EXPECT_EQ(cv::countNonZero(untouched), 0) << "the second match wrote a right map";
    return;
  }
  EXPECT_EQ(differences(readMap(disp[0], size), left16), 0) << params.describe();
  EXPECT_EQ(differences(readMap(disp[1], size), right16), 0) << params.describe();
}

TEST(WtaStage, EqualsReferenceWithSubpixelAndUniqueness) {
  SgmParams p;
  p.num_disparities = 21;
  p.min_disparity = -4;
  expectWtaEqualsReference({37, 23}, p, 81, 255);
  p.uniqueness = 5;  // random sums: a good part of the pixels fails it
  expectWtaEqualsReference({37, 23}, p, 82, 255);
  p.subpixel = false;
  p.paths = 4;
  p.num_disparities = 64;
  p.min_disparity = 25;  // the diagonal search leaves the right row's end without a disparity
  expectWtaEqualsReference({37, 23}, p, 83, 255);
}

TEST(WtaStage, SecondMatchStoresItsMapMirroredBack) {
  SgmParams p;
  p.num_disparities = 21;
  p.uniqueness = 5;
  expectWtaEqualsReference({37, 23}, p, 85, 255, true);
}

TEST(WtaStage, TiesTakeTheSmallestDisparity) {
  SgmParams p;
  p.num_disparities = 13;
  p.uniqueness = 10;
  expectWtaEqualsReference({37, 23}, p, 84, 1);  // costs 0 and 1: ties everywhere
  expectWtaEqualsReference({37, 23}, p, 85, 0);  // all equal: disparity 0 (and min_disparity on the right)
}

// The device's subgroups are those a run asks for (IPS_EXPECT_SUBGROUP_SIZE, set by the CTest entries that run these
// tests on lavapipe with 512-bit vectors, subgroups of 16), so that those entries cannot pass on subgroups of 8.
TEST(VulkanDevice, SubgroupSizeIsTheOneTheRunAsksFor) {
  const char* expected = std::getenv("IPS_EXPECT_SUBGROUP_SIZE");
  if (!expected) GTEST_SKIP() << "no subgroup size asked for (IPS_EXPECT_SUBGROUP_SIZE)";
  const uint32_t size = static_cast<uint32_t>(std::atoi(expected));
#if defined(__x86_64__)
  // lavapipe's 512-bit vectors are certain only where the CPU has them; elsewhere this run repeats the 8-lane one.
  if (size == 16 && context().subgroupSize() == 8 && !__builtin_cpu_supports("avx512f"))
    GTEST_SKIP() << "this CPU has no AVX-512: lavapipe kept subgroups of 8";
#endif
  EXPECT_EQ(context().subgroupSize(), size);
}

// Every workgroup of the lane shaders is one whole subgroup: each of its invocations has its own lane, 0 .. size - 1,
// in a subgroup of the device's size. A device that splits such a workgroup into partial subgroups would give lanes
// twice and leave some of every row's disparities unwritten. (lavapipe with 1024- or 2048-bit vectors, beyond this
// CPU's 512, reports subgroups of 32 or 64 but counts only 16 lanes, full subgroups asked for or not: this test
// fails there, and so do the stages.)
TEST(VulkanDevice, LaneShadersRunOnWholeSubgroups) {
  const uint32_t size = context().subgroupSize();
  constexpr uint32_t kGroups = 5;
  vk::Buffer lanes = hostBuffer(size * kGroups * 4, 0xFF);
  vk::DescriptorPool pool = makePool();
  vk::Pipeline pipeline(pool, "subgroup_lanes", {{0, lanes}}, 0,
                        {{E3D_SPEC_SUBGROUP_SIZE, static_cast<int32_t>(size)}});
  runOnDevice([&](VkCommandBuffer cmd) {
    pipeline.bind(cmd);
    vkCmdDispatch(cmd, kGroups, 1, 1);
  });
  const auto* words = static_cast<const uint32_t*>(lanes.mapped());
  for (uint32_t g = 0; g < kGroups; ++g) {
    std::vector<int> seen(size, 0);
    for (uint32_t i = 0; i < size; ++i) {
      const uint32_t w = words[g * size + i], lane = w & 0xFFFFu;
      EXPECT_EQ(w >> 16, size) << "workgroup " << g << " invocation " << i << ": the subgroup's size";
      if (lane < size) ++seen[lane];
    }
    for (uint32_t lane = 0; lane < size; ++lane)
      EXPECT_EQ(seen[lane], 1) << "workgroup " << g << ": lane " << lane << " of " << size;
  }
}

// ---- sgm_aggregate_rowpass (rows) ----

// The two phases of the row passes (aggregation and selection fused; census costs computed on the fly from the
// census codes, the other costs read from the cost volume) against winnerTakesAll(aggregateCosts(costVolume)): one
// stage, though it does the work of two.
// rows_per_dispatch > 0: each walk split into dispatches of that many rows (the state carried over in the scratch).
void expectRowPassesEqualReference(const cv::Mat& left, const cv::Mat& right, SgmParams params,
                                   int rows_per_dispatch = 0) {
  VulkanContext& ctx = context();
  const cv::Size size = left.size();
  params.aggregation = Aggregation::rows;
  RowsPlan plan = planLayout(size, params, DeviceLimits::of(ctx)).row_passes;
  if (rows_per_dispatch > 0) plan.rows_per_dispatch = rows_per_dispatch;
  const VkDevice dev = ctx.device();
  const std::vector<uint8_t> costs = costVolume(left, right, params);
  vk::Buffer image = imageBuffer(left), census[2] = {hostBuffer(size.area() * 4), hostBuffer(size.area() * 4)};
  const cv::Mat codes[2] = {census5x5(left), census5x5(right)};
  for (int i = 0; i < 2; ++i) std::memcpy(census[i].mapped(), codes[i].data, size.area() * 4);
  vk::Buffer scratch = hostBuffer(plan.scratch_bytes), sums = hostBuffer(plan.sum_bytes);
  // The cost volume: one buffer, read as texels (for census a placeholder the shader does not read).
  const Volume volume(size.height, plan.cost_volume ? plan.cost_row_bytes : 16, size.height);
  if (plan.cost_volume) writeSlice(volume, 0, size, params.num_disparities, plan.lanes, costs);
  std::vector<vk::Descriptor> sum_chunks;
  for (const ChunkRange& r : rowRanges(plan.sum_row_bytes, size.height, plan.rows_per_chunk))
    sum_chunks.push_back({sums.handle(), r.offset, r.bytes});
  const vk::BufferView image_bytes(dev, image, VK_FORMAT_R8_UINT);
  const vk::BufferView census_words[2] = {vk::BufferView(dev, census[0], VK_FORMAT_R32_UINT),
                                          vk::BufferView(dev, census[1], VK_FORMAT_R32_UINT)};
  const vk::BufferView scratch16(dev, scratch, VK_FORMAT_R32G32B32A32_UINT);
  const vk::BufferView scratch8(dev, scratch, VK_FORMAT_R32G32_UINT);
  const vk::BufferView sums16(dev, sums, VK_FORMAT_R32G32B32A32_UINT);
  const vk::BufferView costs16(dev, volume.buffer(0), VK_FORMAT_R32G32B32A32_UINT);
  const vk::BufferView costs8(dev, volume.buffer(0), VK_FORMAT_R32G32_UINT);
  vk::Buffer disp[2] = {hostBuffer(size.area() * 4), hostBuffer(size.area() * 4)};
  const RowPassStage::Buffers buffers{image_bytes, census_words[0], census_words[1], scratch16, scratch8, scratch,
                                      sum_chunks,  sums16,          disp[0],         disp[1],   costs16,  costs8};
  vk::DescriptorPool pool = makePool();
  RowPassStage stage(pool, ctx.subgroupSize(), size, params, buffers, plan, {0, false, true});
  runOnDevice([&](VkCommandBuffer cmd) {
    stage.record(cmd, 0);
    stage.record(cmd, 1);
  });
  cv::Mat left16, right16;
  winnerTakesAll(aggregateCosts(left, costs, params), size, params, left16, right16);
  const std::string layout = " pixels per subgroup " + std::to_string(plan.pixels_per_subgroup) + ", " +
                             std::to_string(plan.rows_per_dispatch) + " rows per dispatch";
  EXPECT_EQ(differences(readMap(disp[0], size), left16), 0) << params.describe() << layout;
  EXPECT_EQ(differences(readMap(disp[1], size), right16), 0) << params.describe() << layout;
}

TEST(RowPassStage, EqualsReference) {
  if (!context().supportsRowLayout()) GTEST_SKIP() << "the device cannot run the row passes";
  cv::Mat left, right;
  shiftedPair(91, 7, left, right);
  SgmParams p;
  p.num_disparities = 21;
  p.min_disparity = -2;
  p.uniqueness = 5;
  expectRowPassesEqualReference(left, right, p);
  p.paths = 4;
  p.subpixel = false;
  expectRowPassesEqualReference(left, right, p);
  SgmParams sad = SgmParams::forCost(Cost::sad);  // from the cost volume
  sad.num_disparities = 30;
  expectRowPassesEqualReference(left, right, sad);
  const cv::Mat flat(left.size(), CV_8UC1, cv::Scalar(100));
  expectRowPassesEqualReference(flat, flat, p);
}

// Several pixels per subgroup (rows walked together by lane groups, each two columns behind the one before): the
// same maps for every count the subgroup allows, also where a dispatch's rows leave the last groups without a row
// (5 rows per dispatch) and where each dispatch is one row (the lag starts again in every one).
TEST(RowPassStage, EveryPixelsPerSubgroupEqualsReference) {
  if (!context().supportsRowLayout()) GTEST_SKIP() << "the device cannot run the row passes";
  cv::Mat left, right;
  shiftedPair(93, 9, left, right);
  const int sg = static_cast<int>(context().subgroupSize());
  for (int pixels = 1; pixels <= sg; pixels *= 2) {
    SgmParams p;
    p.num_disparities = 21;
    p.min_disparity = -2;
    p.uniqueness = 5;
    p.row_pixels = pixels;
    expectRowPassesEqualReference(left, right, p);
    expectRowPassesEqualReference(left, right, p, 5);
    expectRowPassesEqualReference(left, right, p, 1);
    p.paths = 4;
    p.num_disparities = 70;
    p.min_disparity = 3;
    expectRowPassesEqualReference(left, right, p, 7);
    SgmParams sad = SgmParams::forCost(Cost::sad);  // the cost volume, written with the subgroup's lanes
    sad.num_disparities = 30;
    sad.row_pixels = pixels;
    expectRowPassesEqualReference(left, right, sad, 5);
  }
}

// How many pixels a subgroup of the row passes takes: the least padding of the range with at most 32 disparities per
// lane, among equal paddings the most pixels with at most 16 (with a cost volume the cost stage's lanes need 4-byte
// words); a given count as given, none beyond the subgroup.
TEST(LayoutPlan, RowPassesTakeTheLeastPaddingThenTheMostPixelsWithSixteenDisparitiesPerLane) {
  DeviceLimits limits;  // a CPU device with subgroups of 8
  const cv::Size size(640, 480);
  const auto plan = [&](Cost cost, int num_disparities, int row_pixels = 0) {
    SgmParams p = SgmParams::forCost(cost);
    p.num_disparities = num_disparities;
    p.row_pixels = row_pixels;
    return planLayout(size, p, limits).row_passes;
  };
  // {range, pixels per subgroup, disparities per lane}
  const int expected[][3] = {{8, 8, 8},   {16, 8, 16}, {17, 8, 24},  {32, 4, 16}, {48, 4, 24},
                             {64, 2, 16}, {80, 2, 24}, {128, 1, 16}, {256, 1, 32}};
  for (const auto& e : expected) {
    const RowsPlan r = plan(Cost::census, e[0]);
    EXPECT_EQ(r.pixels_per_subgroup, e[1]) << "census D=" << e[0];
    EXPECT_EQ(r.lanes.lane_disps, e[2]) << "census D=" << e[0];
    EXPECT_EQ(r.lanes.padded_disps, e[2] * 8 / e[1]) << "census D=" << e[0];
  }
  const RowsPlan sad16 = plan(Cost::sad, 16);  // 8 pixels would need 32 per lane (4-byte words on 8 lanes)
  EXPECT_EQ(sad16.pixels_per_subgroup, 4);
  EXPECT_EQ(sad16.lanes.lane_disps, 16);
  EXPECT_EQ(sad16.cost_lanes.padded_disps, sad16.lanes.padded_disps);  // the volume is [y][x][d] for both stages
  EXPECT_EQ(sad16.cost_lanes.lane_disps * 8, sad16.cost_lanes.padded_disps);
  EXPECT_EQ(sad16.cost_lanes.lane_disps % 4, 0);  // the cost stage's 8 lanes hold 4-byte words
  EXPECT_EQ(plan(Cost::census, 128, 2).pixels_per_subgroup, 2);
  EXPECT_EQ(plan(Cost::census, 128, 2).lanes.lane_disps, 32);
  EXPECT_THROW(plan(Cost::census, 128, 16), std::invalid_argument);
  SgmParams odd;
  odd.row_pixels = 3;
  EXPECT_THROW(odd.validate(), std::invalid_argument);
}

// ---- mi_histogram, mi_table ----

// The reference's joint histogram as the histogram buffer holds it: 65536 bins [left grey][right grey], then the count.
std::vector<uint32_t> referenceHistogram(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16) {
  const JointHistogram h = miJointHistogram(left, right, disparity16);
  std::vector<uint32_t> out(h.bins.begin(), h.bins.end());
  out.push_back(static_cast<uint32_t>(h.count));
  return out;
}

// The table stage's buffers for `regions` regions (the histograms host-visible).
struct MiTableBuffers {
  explicit MiTableBuffers(int regions = 1)
      : histogram(hostBuffer(static_cast<size_t>(regions) * E3D_MI_HISTOGRAM_ENTRIES * 4, 0)),
        log2(hostBuffer(256 * 4)),
        work64(hostBuffer(static_cast<size_t>(regions) * E3D_MI_WORK64_ENTRIES * 8)),
        work32(hostBuffer(static_cast<size_t>(regions) * E3D_MI_WORK32_ENTRIES * 4)),
        table(hostBuffer(static_cast<size_t>(regions) * E3D_MI_TABLE_BYTES)) {
    std::memcpy(log2.mapped(), log2FractionTable().data(), 256 * 4);
  }
  vk::Buffer histogram, log2, work64, work32, table;
  cv::Mat readTable(int region = 0) const {
    return cv::Mat(256, 256, CV_8UC1, static_cast<uint8_t*>(table.mapped()) + region * E3D_MI_TABLE_BYTES).clone();
  }
  std::vector<uint32_t> readHistogram(int region) const {
    const uint32_t* bins = static_cast<const uint32_t*>(histogram.mapped()) + region * E3D_MI_HISTOGRAM_ENTRIES;
    return std::vector<uint32_t>(bins, bins + E3D_MI_HISTOGRAM_ENTRIES);
  }
};

// The image the table learns from: a grey mapping (right = 0.6 left + 20) with noise, so that the table has a
// valley to find.
void miPair(cv::Size size, uint64_t seed, cv::Mat& left, cv::Mat& right) {
  left = randomImage(size, seed);
  left.convertTo(right, CV_8U, 0.6, 20);
  right += randomImage(size, seed + 1, 0, 8);
}

TEST(MiTableStage, EqualsReferenceFromAHistogram) {
  cv::Mat left, right;
  miPair({37, 23}, 101, left, right);
  MiTableBuffers b;
  const cv::Mat zero(left.size(), CV_16S, cv::Scalar(0));
  const std::vector<uint32_t> histogram = referenceHistogram(left, right, zero);
  std::memcpy(b.histogram.mapped(), histogram.data(), histogram.size() * 4);
  vk::DescriptorPool pool = makePool();
  MiTableStage stage(pool, b.histogram, b.log2, b.work64, b.work32, b.table, 1);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  const cv::Mat expected = miTable(left, right, zero);
  EXPECT_EQ(differences(b.readTable(), expected), 0);
  double lo = 0, hi = 0;
  cv::minMaxLoc(expected, &lo, &hi);
  EXPECT_LT(lo, hi);  // not a uniform table
}

TEST(MiTableStage, EmptyHistogramGivesTheUniformTable) {
  const cv::Mat image = randomImage({37, 23}, 102);
  MiTableBuffers b;  // histogram zeroed
  vk::DescriptorPool pool = makePool();
  MiTableStage stage(pool, b.histogram, b.log2, b.work64, b.work32, b.table, 1);
  runOnDevice([&](VkCommandBuffer cmd) { stage.record(cmd); });
  const cv::Mat none(image.size(), CV_16S, cv::Scalar(kInvalidDisparity));
  EXPECT_EQ(differences(b.readTable(), miTable(image, image, none)), 0);
}

// The histogram stage with a guide, read back, then the table stage on it: the histogram and table of each region
// of params' grid (region-major).
struct MiHistogramRun {
  std::vector<std::vector<uint32_t>> histograms;
  std::vector<cv::Mat> tables;
  // Of the first region (the image's with 1 x 1).
  const std::vector<uint32_t>& histogram() const { return histograms.front(); }
  const cv::Mat& table() const { return tables.front(); }
};
MiHistogramRun runMiHistogram(const cv::Mat& left, const cv::Mat& right, const cv::Mat& guide16,
                              MiHistogramStage::Guide mode, const SgmParams& params) {
  ImagePair images(left, right);
  vk::Buffer guide = mapBuffer(guide16.empty() ? cv::Mat(1, 1, CV_16S, cv::Scalar(0)) : guide16);
  const int regions = params.mi_region_columns * params.mi_region_rows;
  MiTableBuffers b(regions);
  vk::DescriptorPool pool = makePool();
  MiHistogramStage histogram(pool, left.size(), guide16.empty() ? left.size() : guide16.size(), images.words, guide,
                             b.histogram, params);
  MiTableStage table(pool, b.histogram, b.log2, b.work64, b.work32, b.table, regions);
  runOnDevice([&](VkCommandBuffer cmd) {
    histogram.record(cmd, mode);
    table.record(cmd);
  });
  MiHistogramRun run;
  for (int r = 0; r < regions; ++r) {
    run.histograms.push_back(b.readHistogram(r));
    run.tables.push_back(b.readTable(r));
  }
  return run;
}

// The device's histograms and tables of every region against miJointHistograms and miTables of `map`.
void expectRegionsEqualReference(const MiHistogramRun& run, const cv::Mat& left, const cv::Mat& right,
                                 const cv::Mat& map, const SgmParams& params) {
  const std::vector<JointHistogram> expected =
      miJointHistograms(left, right, map, params.mi_region_columns, params.mi_region_rows);
  const MiTables tables = miTables(left, right, map, params.mi_region_columns, params.mi_region_rows);
  ASSERT_EQ(run.histograms.size(), expected.size());
  for (size_t r = 0; r < expected.size(); ++r) {
    std::vector<uint32_t> bins(expected[r].bins.begin(), expected[r].bins.end());
    bins.push_back(static_cast<uint32_t>(expected[r].count));
    EXPECT_EQ(run.histograms[r], bins) << "region " << r;
    EXPECT_EQ(differences(run.tables[r], tables.tables[r]), 0) << "region " << r;
  }
}

TEST(MiHistogramStage, OwnGuideCountsTheMatchedPairs) {
  cv::Mat left, right;
  miPair({37, 23}, 103, left, right);
  SgmParams p = SgmParams::forCost(Cost::mi);
  p.mi_region_columns = p.mi_region_rows = 1;  // one table (the regions: below)
  // Disparity 0: every pixel counted, in its own column.
  const cv::Mat zero(left.size(), CV_16S, cv::Scalar(0));
  const MiHistogramRun at_zero = runMiHistogram(left, right, zero, MiHistogramStage::Guide::own, p);
  EXPECT_EQ(at_zero.histogram(), referenceHistogram(left, right, zero));
  EXPECT_EQ(at_zero.histogram()[65536], left.total());
  EXPECT_EQ(differences(at_zero.table(), miTable(left, right, zero)), 0);
  // A random map with invalid pixels and matches outside the row (both not counted), subpixel values rounded.
  const cv::Mat map = randomMap(left.size(), 104, -3 * 16, 20 * 16, 20);
  const MiHistogramRun run = runMiHistogram(left, right, map, MiHistogramStage::Guide::own, p);
  EXPECT_EQ(run.histogram(), referenceHistogram(left, right, map));
  EXPECT_EQ(differences(run.table(), miTable(left, right, map)), 0);
  EXPECT_LT(run.histogram()[65536], left.total() * 8 / 10);
  EXPECT_GT(run.histogram()[65536], left.total() / 3);
}

TEST(MiHistogramStage, StartAndBelowGuidesEqualReference) {
  cv::Mat left, right;
  miPair({37, 23}, 105, left, right);
  SgmParams p = SgmParams::forCost(Cost::mi);
  p.mi_region_columns = p.mi_region_rows = 1;  // one table (the regions: below)
  p.num_disparities = 12;
  p.min_disparity = -2;
  // The start of the hierarchy: the pseudo-random disparity of miStartDisparity.
  const MiHistogramRun start = runMiHistogram(left, right, cv::Mat(), MiHistogramStage::Guide::start, p);
  const cv::Mat start_map = miStartDisparity(left.size(), p.min_disparity, p.num_disparities);
  EXPECT_EQ(start.histogram(), referenceHistogram(left, right, start_map));
  EXPECT_EQ(differences(start.table(), miTable(left, right, start_map)), 0);
  // The map of the level below (an odd size's half), doubled.
  const cv::Mat below = randomMap({19, 12}, 106, 0, 6 * 16, 25);
  const MiHistogramRun doubled = runMiHistogram(left, right, below, MiHistogramStage::Guide::below, p);
  const cv::Mat doubled_map = doubleDisparity(below, left.size());
  EXPECT_EQ(doubled.histogram(), referenceHistogram(left, right, doubled_map));
  EXPECT_EQ(differences(doubled.table(), miTable(left, right, doubled_map)), 0);
}

TEST(MiHistogramStage, RegionsCountTheirOwnPixels) {
  cv::Mat left, right;
  miPair({37, 23}, 107, left, right);
  SgmParams p = SgmParams::forCost(Cost::mi);
  p.num_disparities = 12;
  p.min_disparity = -2;
  // The default grid, and an uneven one (37 / 5, 23 / 4).
  for (cv::Size grid : {cv::Size(p.mi_region_columns, p.mi_region_rows), cv::Size(5, 4)}) {
    p.mi_region_columns = grid.width;
    p.mi_region_rows = grid.height;
    const cv::Mat map = randomMap(left.size(), 108, -3 * 16, 20 * 16, 20);
    const MiHistogramRun own = runMiHistogram(left, right, map, MiHistogramStage::Guide::own, p);
    expectRegionsEqualReference(own, left, right, map, p);
    // Every matched pixel in exactly one region: the counts add up to the image's histogram.
    uint64_t counted = 0;
    for (const std::vector<uint32_t>& h : own.histograms) counted += h[65536];
    EXPECT_EQ(counted, miJointHistogram(left, right, map).count);
    const MiHistogramRun start = runMiHistogram(left, right, cv::Mat(), MiHistogramStage::Guide::start, p);
    expectRegionsEqualReference(start, left, right, miStartDisparity(left.size(), p.min_disparity, p.num_disparities),
                                p);
    const cv::Mat below = randomMap({19, 12}, 109, 0, 6 * 16, 25);
    const MiHistogramRun doubled = runMiHistogram(left, right, below, MiHistogramStage::Guide::below, p);
    expectRegionsEqualReference(doubled, left, right, doubleDisparity(below, left.size()), p);
  }
}

}  // namespace
