#include "ips/sim/stereo_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <stdexcept>
#include <vector>

namespace ips::sim {

namespace {

// The streaks of motion blur are measured on every 16th pixel in each direction: the image motion varies smoothly
// except at depth edges, and the longest streak sets the number of sub-images.
constexpr int kBlurGridStep = 16;

}  // namespace

StereoRenderer::StereoRenderer(const Scenario& scenario, const World& world, const SensorHead& head,
                               const Trajectory& trajectory)
    : scenario_(scenario),
      world_(world),
      head_(head),
      trajectory_(trajectory),
      scene_(world, scenario.camera.near_m),
      camera_(scenario, head) {
  rect_ = computeRectification(head.calibration);
  Eigen::Matrix3d K_rect;
  K_rect << rect_.f, 0, rect_.cx, 0, rect_.f, rect_.cy, 0, 0, 1;
  rect_view_ = View::pinhole(K_rect, rect_.size);
}

Eigen::Isometry3d StereoRenderer::cameraInWorld(double t, int camera) const {
  const Eigen::Isometry3d T_world_imu = trajectory_.pose(t);
  return camera == 0 ? head_.cam0InWorld(T_world_imu) : head_.cam1InWorld(T_world_imu, t);
}

double StereoRenderer::meanGrey(double t, int camera) const {
  if (!camera_.effects()) throw std::logic_error("StereoRenderer::meanGrey: the camera effects are off");
  cv::Mat radiance;
  scene_.render(camera_.meterView(camera), cameraInWorld(t, camera), t, &radiance, nullptr);
  return camera_.meteredGrey(radiance, camera);
}

Exposure StereoRenderer::exposureFor(int64_t k, int camera) const {
  const CameraFigures& cf = scenario_.camera;
  if (!cf.auto_exposure || k == 0) return camera_.reference();
  const double t_prev = (sampleUtime(scenario_.start_utime, k - 1, cf.rate_hz) - scenario_.start_utime) * 1e-6;
  return camera_.exposureAfter(camera, meanGrey(t_prev, camera));
}

void StereoRenderer::renderWithEffects(int64_t k, int c, double t, const Exposure& e, cv::Mat& out,
                                       int* samples) const {
  const CameraFigures& cf = scenario_.camera;
  const View& v = camera_.view(c);
  // The exposure's middle, with its depth for the streaks.
  const Eigen::Isometry3d T_world_mid = cameraInWorld(t, c);
  cv::Mat radiance, depth, sub;
  scene_.render(v, T_world_mid, t, &radiance, &depth);
  int n_most = 1;
  if (cf.motion_blur) {
    const double exposure_s = e.exposure_us * 1e-6, t_a = t - 0.5 * exposure_s, t_b = t + 0.5 * exposure_s;
    const std::vector<int> n_tile =
        blurSamplesPerTile(depth, c, cameraInWorld(t_a, c), T_world_mid, cameraInWorld(t_b, c), t_a, t_b);
    n_most = *std::max_element(n_tile.begin(), n_tile.end());
    // A tile with n sub-images takes them at the middles of n equal parts of the exposure, t + j / n exposure for
    // j = -(n-1)/2 .. (n-1)/2 (n odd: the middle one is the image rendered above). With n = 3^k these times are among
    // those of n_most: sub-image i of n_most (time i / n_most) serves every tile whose n_most / n divides i.
    const int half = (n_most - 1) / 2;
    std::vector<uint8_t> tiles(n_tile.size());
    for (int i = -half; i <= half; ++i) {
      if (i == 0) continue;
      bool any = false;
      for (size_t k = 0; k < n_tile.size(); ++k) any |= tiles[k] = i % (n_most / n_tile[k]) == 0;
      if (!any) continue;
      const double t_sub = t + exposure_s * i / n_most;
      scene_.render(v, cameraInWorld(t_sub, c), t_sub, &sub, nullptr, &tiles);
      radiance += sub;  // zero outside the tiles drawn
    }
    for (int ty = 0; ty < v.tiles_y; ++ty)
      for (int tx = 0; tx < v.tiles_x; ++tx) {
        const int n = n_tile[static_cast<size_t>(ty) * v.tiles_x + tx];
        if (n == 1) continue;
        const cv::Rect tile(tx * View::kTile, ty * View::kTile, std::min(View::kTile, v.width - tx * View::kTile),
                            std::min(View::kTile, v.height - ty * View::kTile));
        radiance(tile) /= n;
      }
  }
  *samples = n_most;
  camera_.expose(radiance, k, c, e, out);
}

StereoFrame StereoRenderer::render(int64_t k, bool with_gt_disparity) const {
  StereoFrame frame;
  frame.seq = k;
  const FrameTimes times = camera_.times(k);
  frame.utime_true = times.utime_true;
  frame.utime_stamp = times.utime_stamp;
  frame.utime_arrival = times.utime_arrival;
  frame.lost = times.lost;
  if (frame.lost) return frame;
  const CameraFigures& cf = scenario_.camera;
  const double t = (frame.utime_true - scenario_.start_utime) * 1e-6;
  for (int c = 0; c < 2; ++c) {
    const Exposure e = camera_.effects() ? exposureFor(k, c) : camera_.reference();
    frame.exposure_us[c] = e.exposure_us;
    frame.gain_db[c] = (c == 0 ? cf.gain_left_db : cf.gain_right_db) + 20.0 * std::log10(e.gain);
    if (camera_.effects()) renderWithEffects(k, c, t, e, c == 0 ? frame.left : frame.right, &frame.blur_samples[c]);
  }
  if (camera_.effects()) {
    if (with_gt_disparity) frame.gt_disparity = disparityFromDepth(rectifiedDepth(t, 0));
    return frame;
  }
  const Eigen::Isometry3d T_world_imu = trajectory_.pose(t);
  const std::vector<Quad> people = world_.peopleAt(t);
  const std::vector<SceneRenderer::CamQuad> quads[2] = {scene_.prepare(head_.cam0InWorld(T_world_imu), &people),
                                                        scene_.prepare(head_.cam1InWorld(T_world_imu, t), &people)};
  // Without effects the renderer's shading pass applies the camera's gain and noise (SceneRenderer::shadeRow).
  SceneRenderer::Buffers buf[2];
  for (int c = 0; c < 2; ++c) {
    buf[c].z.assign(static_cast<size_t>(camera_.view(c).width) * camera_.view(c).height,
                    std::numeric_limits<float>::infinity());
    buf[c].id.assign(buf[c].z.size(), -1);
  }
  const int ty = camera_.view(0).tiles_y;
  cv::parallel_for_(cv::Range(0, 2 * ty), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) scene_.raster(camera_.view(i / ty), quads[i / ty], buf[i / ty], i % ty);
  });
  frame.left.create(camera_.view(0).height, camera_.view(0).width, CV_8UC1);
  frame.right.create(camera_.view(1).height, camera_.view(1).width, CV_8UC1);
  const int h = camera_.view(0).height;
  const float sigma = static_cast<float>(scenario_.camera.noise_sigma);
  cv::parallel_for_(cv::Range(0, 2 * h), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) {
      const int c = i / h, y = i % h;
      cv::Mat& out = c == 0 ? frame.left : frame.right;
      scene_.shadeRow(camera_.view(c), quads[c], buf[c], y, camera_.gain(c), sigma, camera_.noiseSeed(k, c, y),
                      out.ptr<uint8_t>(y), nullptr);
    }
  });
  if (with_gt_disparity) frame.gt_disparity = disparityFromDepth(rectifiedDepth(t, 0));
  return frame;
}

std::vector<int> StereoRenderer::blurSamplesPerTile(const cv::Mat& depth, int c, const Eigen::Isometry3d& T_world_a,
                                                    const Eigen::Isometry3d& T_world_mid,
                                                    const Eigen::Isometry3d& T_world_b, double t_a, double t_b) const {
  const View& v = camera_.view(c);
  const ips::CameraIntrinsics& cam = c == 0 ? head_.calibration.cam0 : head_.calibration.cam1;
  // The points seen on a grid of pixels at the exposure's middle, where they are at its start and end, each in the
  // camera of that time. A point on a person (within kOnPerson_m of its box at the middle) moves with the person.
  constexpr double kOnPerson_m = 0.05;
  const double t_mid = 0.5 * (t_a + t_b);
  const Eigen::Isometry3d T_a_world = T_world_a.inverse(), T_b_world = T_world_b.inverse();
  auto personAt = [&](const Person& person, double time) {
    const Eigen::Vector2d centre = person.centre(time);
    return Eigen::Vector3d(centre.x(), centre.y(), world_.ramp.floorHeight(centre));
  };
  std::vector<Eigen::Vector3d> people_mid;  // the foot of each box's centre at the middle
  for (const Person& person : world_.people) people_mid.push_back(personAt(person, t_mid));
  std::vector<cv::Point3d> at_a, at_b;
  std::vector<cv::Point2d> grid_px;
  for (int y = kBlurGridStep / 2; y < v.height; y += kBlurGridStep)
    for (int x = kBlurGridStep / 2; x < v.width; x += kBlurGridStep) {
      const size_t i = static_cast<size_t>(y) * v.width + x;
      const double z = depth.at<float>(y, x);
      if (!(z > 0)) continue;
      Eigen::Vector3d p_a = T_world_mid * Eigen::Vector3d(v.rx[i] * z, v.ry[i] * z, z), p_b = p_a;
      for (size_t k = 0; k < world_.people.size(); ++k) {
        const Person& person = world_.people[k];
        const Eigen::Vector3d d = p_a - people_mid[k];
        const Eigen::Vector2d along = person.forward(), across(-along.y(), along.x());
        const Eigen::Vector2d d2 = d.head<2>();
        if (std::abs(d2.dot(across)) > 0.5 * person.size_m.x() + kOnPerson_m ||
            std::abs(d2.dot(along)) > 0.5 * person.size_m.y() + kOnPerson_m || d.z() < -kOnPerson_m ||
            d.z() > person.size_m.z() + kOnPerson_m)
          continue;
        p_b += personAt(person, t_b) - people_mid[k];
        p_a += personAt(person, t_a) - people_mid[k];
        break;
      }
      p_a = T_a_world * p_a;
      p_b = T_b_world * p_b;
      at_a.emplace_back(p_a.x(), p_a.y(), p_a.z());
      at_b.emplace_back(p_b.x(), p_b.y(), p_b.z());
      grid_px.emplace_back(x, y);
    }
  auto project = [&](const std::vector<cv::Point3d>& pts) {
    std::vector<cv::Point2d> px;
    if (pts.empty()) return px;
    const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
    if (cam.model == ips::DistortionModel::kEquidistant)
      cv::fisheye::projectPoints(pts, px, zero, zero, cam.cvK(), cam.cvDistortion());
    else
      cv::projectPoints(pts, zero, zero, cam.cvK(), cam.cvDistortion(), px);
    return px;
  };
  const std::vector<cv::Point2d> pa = project(at_a), pb = project(at_b);
  // The longest streak that reaches each tile. A streak drawn at the exposure's middle at a grid point runs half its
  // length either way along the image motion, so it counts in every tile within that distance.
  std::vector<float> streak(static_cast<size_t>(v.tiles_x) * v.tiles_y, 0.0f);
  for (size_t i = 0; i < pa.size(); ++i) {
    const double length = cv::norm(pb[i] - pa[i]), r = 0.5 * length;
    const cv::Point2d& mid = grid_px[i];
    const int tx0 = std::max(0, static_cast<int>(std::floor((mid.x - r) / View::kTile)));
    const int tx1 = std::min(v.tiles_x - 1, static_cast<int>(std::floor((mid.x + r) / View::kTile)));
    const int ty0 = std::max(0, static_cast<int>(std::floor((mid.y - r) / View::kTile)));
    const int ty1 = std::min(v.tiles_y - 1, static_cast<int>(std::floor((mid.y + r) / View::kTile)));
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx) {
        float& s = streak[static_cast<size_t>(ty) * v.tiles_x + tx];
        s = std::max(s, static_cast<float>(length));
      }
  }
  std::vector<int> n_tile(streak.size());
  for (size_t k = 0; k < streak.size(); ++k) n_tile[k] = camera_.blurSamples(streak[k]);
  return n_tile;
}

cv::Mat StereoRenderer::rectifiedDepth(double t, int camera) const {
  Eigen::Isometry3d T_cam_rect = Eigen::Isometry3d::Identity();
  T_cam_rect.linear() = (camera == 0 ? rect_.R_rect0_cam0 : rect_.R_rect1_cam1).transpose();
  cv::Mat depth;
  scene_.render(rect_view_, cameraInWorld(t, camera) * T_cam_rect, t, nullptr, &depth);
  return depth;
}

cv::Mat StereoRenderer::disparityFromDepth(const cv::Mat& depth) const {
  cv::Mat disp(depth.size(), CV_32F);
  const float fb = static_cast<float>(rect_.f * rect_.baseline);
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) {
      const float z = depth.at<float>(y, x);
      disp.at<float>(y, x) = z > 0 ? fb / z : 0.0f;
    }
  return disp;
}

}  // namespace ips::sim
