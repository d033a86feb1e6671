#include "ips/calib/vignetting.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace ips::calib {

namespace {

// log G(t) and its derivatives by g1, g2, g3 (t^k / G).
double logGain(const Eigen::Vector3d& g, double t, Eigen::Vector3d* derivative) {
  const double gain = 1 + t * (g[0] + t * (g[1] + t * g[2]));
  if (derivative) *derivative = Eigen::Vector3d(t, t * t, t * t * t) / gain;
  return std::log(gain);
}

// The mean grey of the patch about a sub-pixel position, or a negative value when any of its pixels is clipped or
// it reaches past the image.
double patchMean(const cv::Mat& image, cv::Point2f at, int patch, int lowest, int highest) {
  const int half = patch / 2;
  if (at.x < half + 1 || at.y < half + 1 || at.x >= image.cols - half - 2 || at.y >= image.rows - half - 2) return -1;
  cv::Mat window;
  cv::getRectSubPix(image, cv::Size(patch, patch), at, window, CV_32F);
  double lo = 0, hi = 0;
  cv::minMaxLoc(window, &lo, &hi);
  if (lo < lowest || hi > highest) return -1;
  return cv::mean(window)[0];
}

// The image with its local mean taken out and divided by its local contrast (Gaussian windows of sigma_px), as
// 8 bits for the tracker. The tracker must not see the fall-off: Lucas-Kanade minimises the grey difference of the
// two windows, so a darker destination pulls the track to where the patch looks as bright as before, and the
// measured ratio shrinks (on the simulated walk the fitted log gain came out 10 % short). A smooth gain is constant
// within the window and cancels here.
cv::Mat contrastNormalised(const cv::Mat& raw, double sigma_px) {
  cv::Mat grey, mean, square_mean;
  raw.convertTo(grey, CV_32F);
  cv::GaussianBlur(grey, mean, cv::Size(), sigma_px);
  cv::GaussianBlur(grey.mul(grey), square_mean, cv::Size(), sigma_px);
  cv::Mat deviation;
  cv::sqrt(cv::max(square_mean - mean.mul(mean), 0.0f), deviation);
  cv::Mat normalised = (grey - mean) / (deviation + 1.0f);
  cv::Mat out;
  normalised.convertTo(out, CV_8U, 40.0, 128.0);  // +-3 local standard deviations within 0..255
  return out;
}

}  // namespace

VignettingAccumulator::VignettingAccumulator(const CameraIntrinsics& camera, const VignettingOptions& options)
    : camera_(camera), options_(options) {
  if (options_.block_px < 1 || options_.patch_px < 1 || options_.max_tracks < 1)
    throw std::invalid_argument("VignettingAccumulator: block_px, patch_px and max_tracks must be positive");
  tan2_ = rayTan2Image(camera_);
  if (options_.source == FlatFieldSource::kFlatTarget) {
    sum_ = cv::Mat::zeros(camera_.height, camera_.width, CV_64F);
    counts_ = cv::Mat::zeros(camera_.height, camera_.width, CV_32S);
  }
}

void VignettingAccumulator::add(const cv::Mat& raw, bool follows_previous) {
  if (raw.type() != CV_8UC1 || raw.cols != camera_.width || raw.rows != camera_.height)
    throw std::invalid_argument("VignettingAccumulator::add: need a CV_8UC1 image of " + std::to_string(camera_.width) +
                                "x" + std::to_string(camera_.height) + ", got " + std::to_string(raw.cols) + "x" +
                                std::to_string(raw.rows) + " of type " + std::to_string(raw.type()));
  ++images_;
  if (options_.source == FlatFieldSource::kFlatTarget) {
    for (int y = 0; y < raw.rows; ++y) {
      const uint8_t* in = raw.ptr<uint8_t>(y);
      double* sum = sum_.ptr<double>(y);
      int* count = counts_.ptr<int>(y);
      for (int x = 0; x < raw.cols; ++x)
        if (in[x] >= options_.lowest_grey && in[x] <= options_.highest_grey) {
          sum[x] += in[x];
          ++count[x];
        }
    }
    return;
  }
  const cv::Mat normalised = contrastNormalised(raw, options_.normalisation_sigma_px);
  if (follows_previous && !previous_.empty()) {
    std::vector<cv::Point2f> from, to, back;
    cv::goodFeaturesToTrack(previous_normalised_, from, options_.max_tracks, 0.01, options_.min_track_distance_px);
    if (!from.empty()) {
      std::vector<uint8_t> found, found_back;
      std::vector<float> error;
      cv::calcOpticalFlowPyrLK(previous_normalised_, normalised, from, to, found, error);
      cv::calcOpticalFlowPyrLK(normalised, previous_normalised_, to, back, found_back, error);
      for (size_t i = 0; i < from.size(); ++i) {
        if (!found[i] || !found_back[i] || cv::norm(back[i] - from[i]) > options_.max_return_px) continue;
        const double before =
            patchMean(previous_, from[i], options_.patch_px, options_.lowest_grey, options_.highest_grey);
        const double after = patchMean(raw, to[i], options_.patch_px, options_.lowest_grey, options_.highest_grey);
        if (before <= 0 || after <= 0) continue;
        const auto t = [&](cv::Point2f p) {
          return tan2_.at<float>(std::clamp(static_cast<int>(std::lround(p.y)), 0, tan2_.rows - 1),
                                 std::clamp(static_cast<int>(std::lround(p.x)), 0, tan2_.cols - 1));
        };
        tracks_.push_back({t(from[i]), t(to[i]), static_cast<float>(std::log(after) - std::log(before)), pairs_});
      }
    }
    ++pairs_;
  }
  raw.copyTo(previous_);
  previous_normalised_ = normalised;
}

VignettingEstimate VignettingAccumulator::estimate() const {
  if (images_ < std::max(options_.min_images, 1))
    throw std::runtime_error("vignetting: " + std::to_string(images_) + " images, need at least " +
                             std::to_string(std::max(options_.min_images, 1)));
  return options_.source == FlatFieldSource::kFlatTarget ? estimateFlatTarget() : estimateMovingScene();
}

VignettingEstimate VignettingAccumulator::finish(const Eigen::Vector3d& gain, double relative_residual) const {
  VignettingEstimate out;
  out.gain = gain;
  out.images = images_;
  out.relative_residual = relative_residual;
  double widest = 0;
  cv::minMaxLoc(tan2_, nullptr, &widest);
  out.widest_tan2 = widest;
  CameraIntrinsics corrected = camera_;
  corrected.vignetting_gain = gain;
  out.corner_gain = corrected.flatFieldGain(widest);
  // A gain that is not positive somewhere in the image would turn greys negative (and loadCalibration refuses it):
  // the images did not show what the source says (a scene given as a flat target, too few views).
  const double lowest = lowestFlatFieldGain(corrected, widest);
  if (!(lowest > 0))
    throw std::runtime_error("vignetting: the fitted gain falls to " + std::to_string(lowest) +
                             " in the image: the images do not show the lens's fall-off as the source says");
  return out;
}

VignettingEstimate VignettingAccumulator::estimateFlatTarget() const {
  const int block = options_.block_px;
  const int blocks_x = camera_.width / block, blocks_y = camera_.height / block;
  const int min_count = std::max(1, static_cast<int>(std::ceil(options_.min_valid_fraction * images_)));
  struct Block {
    double mean, tan2;
  };
  std::vector<Block> blocks;
  for (int by = 0; by < blocks_y; ++by)
    for (int bx = 0; bx < blocks_x; ++bx) {
      double mean = 0, tan2 = 0;
      bool valid = true;
      for (int y = by * block; y < (by + 1) * block && valid; ++y)
        for (int x = bx * block; x < (bx + 1) * block; ++x) {
          const int n = counts_.at<int>(y, x);
          if (n < min_count) {
            valid = false;
            break;
          }
          mean += sum_.at<double>(y, x) / n;
          tan2 += tan2_.at<float>(y, x);
        }
      if (!valid) continue;
      const double pixels = static_cast<double>(block) * block;
      blocks.push_back({mean / pixels, tan2 / pixels});
    }
  if (blocks.size() < 16)
    throw std::runtime_error("vignetting: " + std::to_string(blocks.size()) +
                             " blocks of the image were unclipped in enough images; too few to fit");
  double overall = 0;
  for (const Block& b : blocks) overall += b.mean;
  overall /= static_cast<double>(blocks.size());
  if (!(overall > 0)) throw std::runtime_error("vignetting: the images are black");
  // m G(t) = s, m = mean / overall: s - g1 m t - g2 m t^2 - g3 m t^3 = m, linear in g and the level s.
  Eigen::MatrixXd a(static_cast<Eigen::Index>(blocks.size()), 4);
  Eigen::VectorXd rhs(static_cast<Eigen::Index>(blocks.size()));
  for (size_t i = 0; i < blocks.size(); ++i) {
    const double m = blocks[i].mean / overall, t = blocks[i].tan2;
    const auto row = static_cast<Eigen::Index>(i);
    a.row(row) << -m * t, -m * t * t, -m * t * t * t, 1;
    rhs(row) = m;
  }
  const Eigen::VectorXd x = a.colPivHouseholderQr().solve(rhs);
  const double rms = std::sqrt((a * x - rhs).squaredNorm() / static_cast<double>(blocks.size()));
  return finish(x.head<3>(), rms / x(3));
}

VignettingEstimate VignettingAccumulator::estimateMovingScene() const {
  if (tracks_.size() < 100)
    throw std::runtime_error("vignetting: " + std::to_string(tracks_.size()) +
                             " points tracked from one image to the next; need at least 100 (consecutive images of a "
                             "moving head, unclipped)");
  // Residual of a track: its log ratio minus log G(t_from) - log G(t_to) ... with the pair's mean taken out (the
  // exposure change). Gauss-Newton on g from G = 1; then tracks beyond 3 sigma (people walking, occlusions, specular
  // light) are dropped and the fit repeated.
  std::vector<uint8_t> used(tracks_.size(), 1);
  std::vector<double> centred(tracks_.size(), 0.0);  // each used track's residual, its pair's mean taken out
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  double rms = 0;
  for (int round = 0; round < 2; ++round) {
    for (int iteration = 0; iteration < 20; ++iteration) {
      std::vector<double> residual(tracks_.size(), 0.0);
      std::vector<Eigen::Vector3d> jacobian(tracks_.size(), Eigen::Vector3d::Zero());
      std::vector<double> pair_residual(static_cast<size_t>(pairs_), 0.0);
      std::vector<Eigen::Vector3d> pair_jacobian(static_cast<size_t>(pairs_), Eigen::Vector3d::Zero());
      std::vector<int> pair_count(static_cast<size_t>(pairs_), 0);
      for (size_t i = 0; i < tracks_.size(); ++i) {
        if (!used[i]) continue;
        const Track& k = tracks_[i];
        Eigen::Vector3d d_from, d_to;
        // grey_to / grey_from = V(t_to) / V(t_from) x exposure: log ratio + log G(t_to) - log G(t_from) = level.
        residual[i] = k.log_ratio + logGain(g, k.tan2_to, &d_to) - logGain(g, k.tan2_from, &d_from);
        jacobian[i] = d_to - d_from;
        pair_residual[static_cast<size_t>(k.pair)] += residual[i];
        pair_jacobian[static_cast<size_t>(k.pair)] += jacobian[i];
        ++pair_count[static_cast<size_t>(k.pair)];
      }
      Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
      Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
      double squares = 0;
      size_t count = 0;
      for (size_t i = 0; i < tracks_.size(); ++i) {
        if (!used[i]) continue;
        const auto p = static_cast<size_t>(tracks_[i].pair);
        const double r = centred[i] = residual[i] - pair_residual[p] / pair_count[p];
        const Eigen::Vector3d j = jacobian[i] - pair_jacobian[p] / pair_count[p];
        normal += j * j.transpose();
        gradient += j * r;
        squares += r * r;
        ++count;
      }
      rms = std::sqrt(squares / static_cast<double>(count));
      const Eigen::Vector3d step = normal.ldlt().solve(-gradient);
      g += step;
      if (step.norm() < 1e-7) break;
    }
    // Drop the outliers of the converged fit (its last iteration's residuals) and fit again.
    if (round == 0)
      for (size_t i = 0; i < tracks_.size(); ++i) used[i] = std::abs(centred[i]) <= 3 * rms;
  }
  return finish(g, rms);
}

}  // namespace ips::calib
