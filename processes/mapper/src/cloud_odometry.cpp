#include "ips/mapper/cloud_odometry.hpp"

#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>

#include <Eigen/Eigenvalues>
#include <cmath>

namespace ips::mapper {

namespace {

std::shared_ptr<open3d::geometry::PointCloud> thinned(const std::vector<Eigen::Vector3d>& points, double voxel) {
  open3d::geometry::PointCloud cloud;
  cloud.points_ = points;
  return cloud.VoxelDownSample(voxel);
}

void positive(const Config& cfg, const char* key, double v) {
  if (!(v > 0)) throw ConfigError(cfg.path() + ": key '" + key + "' must be positive");
}

}  // namespace

CloudOdometryParams CloudOdometryParams::fromConfig(const Config& cfg) {
  CloudOdometryParams p;
  p.voxel_size_m = cfg.getDouble("cloud_odometry/voxel_size_m", p.voxel_size_m);
  p.normal_radius_m = cfg.getDouble("cloud_odometry/normal_radius_m", p.normal_radius_m);
  p.normal_max_neighbours = cfg.getInt("cloud_odometry/normal_max_neighbours", p.normal_max_neighbours);
  p.max_correspondence_m = cfg.getDouble("cloud_odometry/max_correspondence_m", p.max_correspondence_m);
  p.max_iterations = cfg.getInt("cloud_odometry/max_iterations", p.max_iterations);
  p.max_correction_deg = cfg.getDouble("cloud_odometry/max_correction_deg", p.max_correction_deg);
  p.min_overlap = cfg.getDouble("cloud_odometry/min_overlap", p.min_overlap);
  p.min_correspondences = cfg.getInt("cloud_odometry/min_correspondences", p.min_correspondences);
  p.covariance_inflation = cfg.getDouble("cloud_odometry/covariance_inflation", p.covariance_inflation);
  p.min_residual_sigma_m = cfg.getDouble("cloud_odometry/min_residual_sigma_m", p.min_residual_sigma_m);
  p.unconstrained_sigma_t = cfg.getDouble("cloud_odometry/unconstrained_sigma_t", p.unconstrained_sigma_t);
  p.unconstrained_sigma_r = cfg.getDouble("cloud_odometry/unconstrained_sigma_r", p.unconstrained_sigma_r);
  p.constrained_factor = cfg.getDouble("cloud_odometry/constrained_factor", p.constrained_factor);
  p.robust_sigmas = cfg.getDouble("cloud_odometry/robust_sigmas", p.robust_sigmas);
  positive(cfg, "cloud_odometry/voxel_size_m", p.voxel_size_m);
  positive(cfg, "cloud_odometry/normal_radius_m", p.normal_radius_m);
  positive(cfg, "cloud_odometry/max_correspondence_m", p.max_correspondence_m);
  positive(cfg, "cloud_odometry/max_correction_deg", p.max_correction_deg);
  positive(cfg, "cloud_odometry/covariance_inflation", p.covariance_inflation);
  positive(cfg, "cloud_odometry/min_residual_sigma_m", p.min_residual_sigma_m);
  positive(cfg, "cloud_odometry/unconstrained_sigma_t", p.unconstrained_sigma_t);
  positive(cfg, "cloud_odometry/unconstrained_sigma_r", p.unconstrained_sigma_r);
  positive(cfg, "cloud_odometry/constrained_factor", p.constrained_factor);
  positive(cfg, "cloud_odometry/robust_sigmas", p.robust_sigmas);
  if (p.normal_max_neighbours < 3 || p.max_iterations < 1 || p.min_correspondences < 6)
    throw ConfigError(cfg.path() +
                      ": cloud_odometry needs normal_max_neighbours >= 3, max_iterations >= 1 and "
                      "min_correspondences >= 6");
  if (!(p.min_overlap >= 0 && p.min_overlap <= 1))
    throw ConfigError(cfg.path() + ": key 'cloud_odometry/min_overlap' must be in [0, 1]");
  return p;
}

// The previous map: its time, its camera's pose as the filter gave it, and its points in that camera's frame.
struct CloudOdometry::Reference {
  int64_t utime = 0;
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector3d> points;  // camera 0 at utime
};

CloudOdometry::CloudOdometry(const CloudOdometryParams& params) : params_(params) {}
CloudOdometry::~CloudOdometry() = default;

CloudDelta CloudOdometry::add(int64_t utime, const std::vector<Eigen::Vector3d>& world_points,
                              const Eigen::Isometry3d& T_world_cam, double depth_sigma_per_m2) {
  auto ref = std::make_unique<Reference>();
  ref->utime = utime;
  ref->T_world_cam = T_world_cam;
  const Eigen::Isometry3d T_cam_world = T_world_cam.inverse();
  ref->points.reserve(world_points.size());
  for (const Eigen::Vector3d& p : world_points) ref->points.push_back(T_cam_world * p);
  CloudDelta d;
  if (prev_) {
    d = align(prev_->points, ref->points, prev_->T_world_cam.inverse() * T_world_cam, depth_sigma_per_m2);
    d.utime_prev = prev_->utime;
  } else {
    d.reason = "first_map";
  }
  d.utime = utime;
  prev_ = std::move(ref);
  return d;
}

CloudDelta CloudOdometry::align(const std::vector<Eigen::Vector3d>& prev, const std::vector<Eigen::Vector3d>& now,
                                const Eigen::Isometry3d& prior, double depth_sigma_per_m2) const {
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  CloudDelta d;
  d.prior = prior;
  d.T_prev_now = prior;
  const auto target = thinned(prev, params_.voxel_size_m);
  const auto source = thinned(now, params_.voxel_size_m);
  d.points = static_cast<int>(source->points_.size());
  if (static_cast<int>(target->points_.size()) < params_.min_correspondences ||
      d.points < params_.min_correspondences) {
    d.reason = "too_few_points";
    return d;
  }
  target->EstimateNormals(
      open3d::geometry::KDTreeSearchParamHybrid(params_.normal_radius_m, params_.normal_max_neighbours));
  const open3d::geometry::KDTreeFlann tree(*target);

  // Point-to-plane alignment as a maximum a posteriori estimate: the pairs' residuals n . (R p + t - y) and the
  // prior, with the weak information of the unconstrained sigmas. Open3D's own ICP solves the pairs alone, and in a
  // corridor, whose axis the walls leave open, it slides by metres (on the simulated walk: towards no motion at
  // all); the prior's term keeps such a direction where the filter put it, while every direction the maps constrain
  // follows them. Steps in the filter's error terms: t + dt, Exp(dtheta) R.
  Vector6d weak;
  weak << Eigen::Vector3d::Constant(1.0 / (params_.unconstrained_sigma_t * params_.unconstrained_sigma_t)),
      Eigen::Vector3d::Constant(1.0 / (params_.unconstrained_sigma_r * params_.unconstrained_sigma_r));
  const Matrix6d D = weak.cwiseInverse().cwiseSqrt().asDiagonal();  // the unconstrained sigmas
  const double min_eigenvalue = params_.constrained_factor * params_.constrained_factor;
  Matrix6d kept = Matrix6d::Identity(), constrained = Matrix6d::Zero();  // of the last iteration, normalised
  Eigen::Matrix3d R = prior.linear();
  Eigen::Vector3d t = prior.translation();
  const double max_d2 = params_.max_correspondence_m * params_.max_correspondence_m;
  const double min_var = params_.min_residual_sigma_m * params_.min_residual_sigma_m;
  std::vector<int> index(1);
  std::vector<double> dist2(1);
  for (int iteration = 0; iteration < params_.max_iterations; ++iteration) {
    Matrix6d H = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    double sum_r2 = 0;
    int pairs = 0;
    double sum_w_r2 = 0;
    for (const Eigen::Vector3d& p : source->points_) {
      const Eigen::Vector3d rp = R * p;
      if (tree.SearchKNN(Eigen::Vector3d(rp + t), 1, index, dist2) < 1 || dist2[0] > max_d2) continue;
      const Eigen::Vector3d& n = target->normals_[index[0]];
      const Eigen::Vector3d& y = target->points_[index[0]];
      const double r = n.dot(rp + t - y);
      // A stereo point's error lies along its viewing ray, sigma = k z |p| (k = sigma_d / (f b)): a residual along
      // the ray of a far point says little.
      const double ray_now = depth_sigma_per_m2 * std::max(p.z(), 0.0) * n.dot(rp);
      const double ray_prev = depth_sigma_per_m2 * std::max(y.z(), 0.0) * n.dot(y);
      const double w_model = 1.0 / (ray_now * ray_now + ray_prev * ray_prev + min_var);
      // Cauchy weight on the residual in its sigmas: a wrong disparity (E3D's bad 2.0 is 10 to 30 % of a map on weak
      // texture) puts a point on no surface, and least squares would follow it.
      const double u = r * r * w_model / (params_.robust_sigmas * params_.robust_sigmas);
      const double w = w_model / (1.0 + u);
      Vector6d J;
      J << n, rp.cross(n);
      H += w * J * J.transpose();
      g += w * J * r;
      sum_r2 += r * r;
      sum_w_r2 += w * r * r;
      ++pairs;
    }
    d.correspondences = pairs;
    if (pairs < params_.min_correspondences) break;
    // The residuals' spread against the model's (1 when the sigmas are right; more when the maps are worse).
    const double variance = std::max(sum_w_r2 / std::max(1, pairs - 6), 1.0);
    d.rmse_m = std::sqrt(sum_r2 / pairs);
    // The pairs' information as the result's covariance will state it (correlated errors: inflated).
    const double scale = 1.0 / (variance * params_.covariance_inflation);
    const Matrix6d info = H * scale;
    const Eigen::AngleAxisd turn(R * prior.linear().transpose());
    Vector6d from_prior;
    from_prior << t - prior.translation(), turn.angle() * turn.axis();
    // In units of the unconstrained sigmas (the prior's information is then the identity), the directions the maps
    // fix less than constrained_factor times better than that are degenerate (Zhang, Kaess and Singh 2016): there
    // the pairs' information and pull are dropped and the step returns to the prior. Left to them, the pairs slide
    // two maps of a straight corridor by metres along its axis, a little more with every iteration.
    const Matrix6d S = D * info * D;
    const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(S);
    const Eigen::Matrix<double, 6, 6> V = eig.eigenvectors();
    Vector6d kept_eigen = eig.eigenvalues();
    Vector6d mask = Vector6d::Ones();
    for (int i = 0; i < 6; ++i)
      if (kept_eigen[i] < min_eigenvalue) kept_eigen[i] = 0, mask[i] = 0;
    kept = V * mask.asDiagonal() * V.transpose();
    constrained = V * kept_eigen.asDiagonal() * V.transpose();
    const Vector6d x =
        -(constrained + Matrix6d::Identity()).ldlt().solve(kept * (D * g * scale) + D.inverse() * from_prior);
    const Vector6d step = D * x;
    t += step.head<3>();
    const double angle = step.tail<3>().norm();
    if (angle > 0) R = Eigen::AngleAxisd(angle, step.tail<3>() / angle).toRotationMatrix() * R;
    if (step.head<3>().norm() < 1e-5 && angle < 1e-6) break;
  }
  d.T_prev_now.linear() = R;
  d.T_prev_now.translation() = t;
  d.overlap = d.points > 0 ? static_cast<double>(d.correspondences) / d.points : 0.0;
  if (d.correspondences < params_.min_correspondences) {
    d.reason = "too_few_correspondences";
    return d;
  }
  if (d.overlap < params_.min_overlap) {
    d.reason = "little_overlap";
    return d;
  }
  const Eigen::AngleAxisd correction(R * prior.linear().transpose());
  if ((t - prior.translation()).norm() > params_.max_correspondence_m ||
      correction.angle() > params_.max_correction_deg * M_PI / 180) {
    d.reason = "diverged";
    return d;
  }
  d.covariance = D * (constrained + Matrix6d::Identity()).inverse() * D;
  d.constrained_directions = static_cast<int>(std::lround(kept.trace()));
  if (!d.T_prev_now.matrix().allFinite() || !d.covariance.allFinite()) {
    d.reason = "not_finite";
    return d;
  }
  d.valid = true;
  return d;
}

}  // namespace ips::mapper
