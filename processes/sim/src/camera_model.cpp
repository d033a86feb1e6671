#include "ips/sim/camera_model.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "ips/sim/rng.hpp"

namespace ips::sim {

namespace {

constexpr int kExposureMeterStep = 4;

}  // namespace

CameraModel::CameraModel(const Scenario& scenario, const SensorHead& head) : scenario_(scenario) {
  raw_[0] = View::distorted(head.calibration.cam0);
  raw_[1] = View::distorted(head.calibration.cam1);
  gain_[0] = static_cast<float>(std::pow(10.0, scenario.camera.gain_left_db / 20.0));
  gain_[1] = static_cast<float>(std::pow(10.0, scenario.camera.gain_right_db / 20.0));
  const CameraFigures& cf = scenario.camera;
  effects_ = cf.motion_blur || cf.auto_exposure || cf.vignetting;
  if (!effects_) return;
  // Natural vignetting: the illumination of a pixel falls with cos^4 of its ray's angle to the optical axis,
  // cos^2 = 1 / (1 + rx^2 + ry^2) for the ray (rx, ry, 1).
  auto illumination = [&](float rx, float ry) {
    const float d2 = 1.0f + rx * rx + ry * ry;
    return cf.vignetting ? 1.0f / (d2 * d2) : 1.0f;
  };
  for (int c = 0; c < 2; ++c) {
    const View& v = raw_[c];
    vignette_[c].resize(v.rx.size());
    for (size_t i = 0; i < v.rx.size(); ++i) vignette_[c][i] = illumination(v.rx[i], v.ry[i]);
    const int step = kExposureMeterStep, w = v.width / step, h = v.height / step;
    std::vector<float> rx(static_cast<size_t>(w) * h), ry(rx.size());
    meter_vignette_[c].resize(rx.size());
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const size_t src = static_cast<size_t>(y * step + step / 2) * v.width + x * step + step / 2;
        const size_t dst = static_cast<size_t>(y) * w + x;
        rx[dst] = v.rx[src], ry[dst] = v.ry[src];
        meter_vignette_[c][dst] = vignette_[c][src];
      }
    meter_view_[c] = View::fromRays(w, h, v.focal / step, std::move(rx), std::move(ry));
  }
}

FrameTimes CameraModel::times(int64_t k) const {
  const CameraFigures& cf = scenario_.camera;
  FrameTimes f;
  f.utime_true = sampleUtime(scenario_.start_utime, k, cf.rate_hz);
  // The stamp's jitter first, then the loss (so that the stamps stay as they are without losses).
  Rng rng(streamSeed(scenario_.seed, kStreamCamera, static_cast<uint64_t>(k)));
  f.utime_stamp = f.utime_true + std::llround(cf.stamp_offset_us + cf.jitter_us * rng.normal());
  f.utime_arrival = f.utime_true + std::llround(cf.latency_us);
  f.lost = cf.frame_loss > 0 && rng.uniform() < cf.frame_loss;
  return f;
}

double CameraModel::meteredGrey(const cv::Mat& radiance, int camera) const {
  const View& v = meter_view_[camera];
  double sum = 0;
  for (int y = 0; y < v.height; ++y)
    for (int x = 0; x < v.width; ++x)
      sum += radiance.at<float>(y, x) * meter_vignette_[camera][static_cast<size_t>(y) * v.width + x];
  return sum / (static_cast<double>(v.width) * v.height);
}

Exposure CameraModel::exposureAfter(int camera, double metered_grey) const {
  const CameraFigures& cf = scenario_.camera;
  // The loop saw the image at grey g with exposure e and gain a; it sets e' a' = e a target / g. The grey is linear in
  // exposure and gain, so e' a' follows from the scene's radiance at the reference exposure alone.
  const double grey = metered_grey * gain_[camera];
  const double max_gain = std::pow(10.0, cf.ae_max_gain_db / 20.0);
  const double needed = grey > 0 ? cf.exposure_us * cf.ae_target_grey / grey : cf.ae_max_exposure_us * max_gain;
  Exposure e;
  e.exposure_us = std::clamp(needed, cf.ae_min_exposure_us, cf.ae_max_exposure_us);
  e.gain = std::clamp(needed / e.exposure_us, 1.0, max_gain);
  return e;
}

int CameraModel::blurSamples(float streak_px) const {
  const CameraFigures& cf = scenario_.camera;
  int n = 1;
  while (n < cf.max_blur_samples && streak_px > n * cf.blur_step_px) n *= 3;
  return n;
}

uint64_t CameraModel::noiseSeed(int64_t k, int camera, int row) const {
  return streamSeed(scenario_.seed, kStreamPixels, (static_cast<uint64_t>(k) * 2 + camera) * raw_[camera].height + row);
}

void CameraModel::expose(const cv::Mat& radiance, int64_t k, int c, const Exposure& e, cv::Mat& out) const {
  const CameraFigures& cf = scenario_.camera;
  const View& v = raw_[c];
  const float scale = static_cast<float>(gain_[c] * e.gain * e.exposure_us / cf.exposure_us);
  const float noise_scale = static_cast<float>(cf.noise_sigma * e.gain) * std::sqrt(3.0f) / 65536.0f;
  out.create(v.height, v.width, CV_8UC1);
  cv::parallel_for_(cv::Range(0, v.height), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) {
      uint64_t state = noiseSeed(k, c, y);
      const size_t row = static_cast<size_t>(y) * v.width;
      uint8_t* o = out.ptr<uint8_t>(y);
      const float* in = radiance.ptr<float>(y);
      for (int x = 0; x < v.width; ++x) {
        const float g = scale * vignette_[c][row + x] * in[x] + noise_scale * irwinHall4(state) + 0.5f;
        o[x] = static_cast<uint8_t>(std::clamp(g, 0.0f, 255.0f));
      }
    }
  });
}

}  // namespace ips::sim
