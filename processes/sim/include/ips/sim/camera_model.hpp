#pragma once
// The simulated cameras' physics, apart from the scene (as ESIM keeps its renderer apart from its camera model): the
// scene renderer gives radiance at a reference exposure; the camera model says when each frame is taken, stamped and
// delivered, which frames are lost, and how radiance becomes the 8-bit image a real camera delivers (fixed gain,
// natural vignetting, the auto exposure loop's exposure and gain, the sub-images motion blur needs, the sensor's
// noise). Every draw comes from the scenario's seed, per frame and per row, so frames render in any order.
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "ips/sim/scenario.hpp"
#include "ips/sim/scene_renderer.hpp"
#include "ips/sim/sensors.hpp"

namespace ips::sim {

// What a camera's exposure loop chose for one image.
struct Exposure {
  double exposure_us = 0;
  double gain = 1;  // linear, on top of the camera's fixed gain
};

// When frame k happened, what its stamp says, when it arrives, and whether it arrives at all.
struct FrameTimes {
  int64_t utime_true = 0;     // exposure mid-time
  int64_t utime_stamp = 0;    // with the camera's stamp offset and jitter
  int64_t utime_arrival = 0;  // delivered after the camera's latency
  bool lost = false;          // dropped on the way (camera/frame_loss)
};

class CameraModel {
 public:
  // Cameras 0 and 1 of the head (their true lenses) with the scenario's camera figures.
  CameraModel(const Scenario& scenario, const SensorHead& head);

  // Frame k's times and loss, from the frame's own camera stream (independent per frame).
  FrameTimes times(int64_t k) const;
  bool frameLost(int64_t k) const { return times(k).lost; }
  // Every pixel's ray through camera 0's or 1's lens: what the scene renderer draws for it.
  const View& view(int camera) const { return raw_[camera]; }
  float gain(int camera) const { return gain_[camera]; }  // the fixed gain, linear
  // Any of the exposure loop, vignetting or motion blur: the image is formed from the whole radiance image (expose);
  // without them the scene renderer's shading applies gain and noise in its own pass (noiseSeed).
  bool effects() const { return effects_; }

  // The exposure loop measures every fourth pixel in each direction (a mean over 1/16 of the image is as good as over
  // all of it, at a sixteenth of the rendering): the rays it measures, and the mean grey of their radiance at the
  // reference exposure with no gain, vignetting included.
  const View& meterView(int camera) const { return meter_view_[camera]; }
  double meteredGrey(const cv::Mat& meter_radiance, int camera) const;
  // The reference exposure (fixed exposure, or the loop's first image).
  Exposure reference() const { return {scenario_.camera.exposure_us, 1.0}; }
  // The loop saw the previous image at meteredGrey g with its exposure: the next exposure and gain bring it to the
  // target grey, the exposure within its limits first, then the gain.
  Exposure exposureAfter(int camera, double metered_grey) const;
  // Motion blur: a tile whose longest streak over the exposure is streak_px long takes 3^k sub-images, for the least
  // k that keeps neighbouring sub-images at most blur_step_px apart, at most max_blur_samples.
  int blurSamples(float streak_px) const;

  // Camera c's 8-bit image k from its radiance (CV_32F, at the reference exposure, the mean over the exposure's
  // sub-images): the fixed gain x the loop's gain x the exposure against the reference x the illumination x the
  // radiance, plus the sensor's noise amplified by the loop's gain, rounded and clipped to 8 bit.
  void expose(const cv::Mat& radiance, int64_t k, int camera, const Exposure& e, cv::Mat& out) const;
  // The seed of the noise of row y of camera c's image k.
  uint64_t noiseSeed(int64_t k, int camera, int row) const;

 private:
  const Scenario& scenario_;
  View raw_[2];
  float gain_[2];
  bool effects_ = false;
  View meter_view_[2];
  std::vector<float> vignette_[2], meter_vignette_[2];  // per pixel illumination factor (1 without vignetting)
};

}  // namespace ips::sim
