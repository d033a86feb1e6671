#include "ips/tracker/motion.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>

namespace ips::tracker {

namespace {

using ips::skew;

// Depth below which a projection is treated as invalid (behind or at the camera).
constexpr double kMinProjectionDepth = 1e-3;

}  // namespace

Eigen::Vector3d RectifiedStereo::triangulate(double xl, double y, double xr) const {
  const double d = xl - xr + disparity_offset;
  const double z = f * baseline / d;
  return {(xl - cx) * z / f, (y - cy) * z / f, z};
}

Eigen::Vector3d RectifiedStereo::project(const Eigen::Vector3d& p) const {
  const double z = std::max(p.z(), kMinProjectionDepth);
  return {f * p.x() / z + cx, f * p.y() / z + cy, f * (p.x() - baseline) / z + cx + disparity_offset};
}

bool alignPointClouds(const std::vector<Eigen::Vector3d>& prev, const std::vector<Eigen::Vector3d>& now,
                      RigidMotion& out) {
  const size_t n = prev.size();
  if (n < 3 || now.size() != n) return false;
  Eigen::Vector3d mean_prev = Eigen::Vector3d::Zero(), mean_now = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mean_prev += prev[i];
    mean_now += now[i];
  }
  mean_prev /= double(n);
  mean_now /= double(n);
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();  // sum (prev - mean)(now - mean)^T
  for (size_t i = 0; i < n; ++i) cross += (prev[i] - mean_prev) * (now[i] - mean_now).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  // Collinear (or coincident) points leave the rotation about their line undetermined.
  if (!(sv(1) > 1e-9 * std::max(1.0, sv(0)))) return false;
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) s(2, 2) = -1;  // no reflection
  out.R = svd.matrixU() * s * svd.matrixV().transpose();
  out.t = mean_prev - out.R * mean_now;
  return true;
}

double forwardReprojectionError2(const RectifiedStereo& cam, const Correspondence& c, const RigidMotion& m) {
  const Eigen::Vector3d p = m.R.transpose() * (c.p_prev - m.t);
  if (p.z() < kMinProjectionDepth) return 1e12;
  const Eigen::Vector3d uv = cam.project(p);
  return (uv - Eigen::Vector3d(c.now.xl, c.now.y, c.now.xr)).squaredNorm();
}

Eigen::Matrix3d RectifiedStereo::projectJacobian(const Eigen::Vector3d& p) const {
  const double z = std::max(p.z(), kMinProjectionDepth), z2 = z * z;
  Eigen::Matrix3d j;
  j << f / z, 0, -f * p.x() / z2, 0, f / z, -f * p.y() / z2, f / z, 0, -f * (p.x() - baseline) / z2;
  return j;
}

Eigen::Matrix3d RectifiedStereo::triangulationCovariance(double xl, double y, double xr, double sigma) const {
  const double d = xl - xr + disparity_offset;
  const double z = f * baseline / d;
  const double dz_dxl = -z / d, dz_dxr = z / d;
  Eigen::Matrix3d j;                                               // rows X Y Z, columns xl y xr
  j << z / f + (xl - cx) / f * dz_dxl, 0, (xl - cx) / f * dz_dxr,  //
      (y - cy) / f * dz_dxl, z / f, (y - cy) / f * dz_dxr,         //
      dz_dxl, 0, dz_dxr;
  return sigma * sigma * j * j.transpose();
}

namespace {

// Whitened forward residual: L^-1 r with S = L L^T the residual's covariance. Returns r^T S^-1 r.
double whitenedForward(const RectifiedStereo& cam, const Correspondence& c, const Eigen::Matrix3d& R,
                       const Eigen::Vector3d& t, const Eigen::Matrix3d& cov_prev, double sigma, Eigen::Vector3d* white,
                       Eigen::Vector3d* raw, Eigen::Matrix<double, 3, 6>* jac = nullptr,
                       Eigen::Vector3d* jac_offset = nullptr) {
  const Eigen::Vector3d p = R.transpose() * (c.p_prev - t);
  if (p.z() < kMinProjectionDepth) {
    if (white) white->setConstant(1e6);
    if (raw) raw->setConstant(1e6);
    if (jac) jac->setZero();
    if (jac_offset) jac_offset->setZero();
    return 1e12;
  }
  const Eigen::Vector3d r = cam.project(p) - Eigen::Vector3d(c.now.xl, c.now.y, c.now.xr);
  const Eigen::Matrix3d J = cam.projectJacobian(p) * R.transpose();
  const Eigen::Matrix3d S = J * cov_prev * J.transpose() + sigma * sigma * Eigen::Matrix3d::Identity();
  Eigen::LLT<Eigen::Matrix3d> llt(S);
  const Eigen::Vector3d w = llt.matrixL().solve(r);
  if (white) *white = w;
  if (raw) *raw = r;
  if (jac) {
    // p = R^T (P - t): dp/dt = -R^T; with R -> R exp([dr]x), dp/dr = [p]x. The weights are held fixed.
    Eigen::Matrix<double, 3, 6> dp;
    dp.leftCols<3>() = -R.transpose();
    dp.rightCols<3>() << 0, -p.z(), p.y(), p.z(), 0, -p.x(), -p.y(), p.x(), 0;
    *jac = llt.matrixL().solve(cam.projectJacobian(p) * dp);
  }
  if (jac_offset) {
    // By the disparity offset: the older point scales with 1 / d (P = (xl - cx, y - cy, f) b / d), and the
    // newer right column's prediction moves with the offset itself.
    const double d = c.prev.xl - c.prev.xr + cam.disparity_offset;
    *jac_offset = llt.matrixL().solve(J * (-c.p_prev / d) + Eigen::Vector3d::UnitZ());
  }
  return w.squaredNorm();
}

}  // namespace

double forwardMahalanobis2(const RectifiedStereo& cam, const Correspondence& c, const RigidMotion& m,
                           const Eigen::Matrix3d& cov_prev, double sigma) {
  return whitenedForward(cam, c, m.R, m.t, cov_prev, sigma, nullptr, nullptr);
}

namespace {

std::vector<Eigen::Matrix3d> prevCovariances(const RectifiedStereo& cam, const std::vector<Correspondence>& corr,
                                             double sigma) {
  std::vector<Eigen::Matrix3d> out(corr.size());
  for (size_t i = 0; i < corr.size(); ++i)
    out[i] = cam.triangulationCovariance(corr[i].prev.xl, corr[i].prev.y, corr[i].prev.xr, sigma);
  return out;
}

RigidMotion refineWithCovariances(const RectifiedStereo& cam, const std::vector<Correspondence>& corr,
                                  const std::vector<Eigen::Matrix3d>& cov_prev, const std::vector<int>& use,
                                  const RigidMotion& initial, int iterations, double sigma, Matrix6d* covariance,
                                  double* rms_px) {
  RigidMotion m = initial;
  Matrix6d jtj = Matrix6d::Zero();
  double chi2 = 0, sum_raw2 = 0;
  for (int iter = 0; iter <= iterations; ++iter) {
    jtj.setZero();
    Eigen::Matrix<double, 6, 1> jtr = Eigen::Matrix<double, 6, 1>::Zero();
    chi2 = 0;
    sum_raw2 = 0;
    for (int idx : use) {
      const Correspondence& c = corr[idx];
      Eigen::Vector3d w0, raw;
      Eigen::Matrix<double, 3, 6> J;  // whitened residual by [dt, dr]
      chi2 += whitenedForward(cam, c, m.R, m.t, cov_prev[idx], sigma, &w0, &raw, &J);
      sum_raw2 += raw.squaredNorm();
      jtj += J.transpose() * J;
      jtr += J.transpose() * w0;
    }
    if (iter == iterations) break;  // the last pass only evaluates J and residuals at the final estimate
    const Eigen::Matrix<double, 6, 1> delta = jtj.ldlt().solve(-jtr);
    if (!delta.allFinite()) break;
    m.t += delta.head<3>();
    m.R = m.R * expSO3(delta.tail<3>());
    if (delta.norm() < 1e-9) iterations = iter + 1;  // converged: one more pass for J at the estimate
  }
  const size_t num_res = use.size() * 3;
  if (rms_px) *rms_px = num_res ? std::sqrt(sum_raw2 / double(num_res)) : 0.0;
  if (covariance) {
    const double dof = std::max<double>(1.0, double(num_res) - 6.0);
    *covariance = (chi2 / dof) * jtj.inverse();
  }
  return m;
}

}  // namespace

RigidMotion refineMotion(const RectifiedStereo& cam, const std::vector<Correspondence>& corr,
                         const std::vector<int>& use, const RigidMotion& initial, int iterations, double sigma,
                         Matrix6d* covariance, double* rms_px) {
  return refineWithCovariances(cam, corr, prevCovariances(cam, corr, sigma), use, initial, iterations, sigma,
                               covariance, rms_px);
}

DisparityOffsetObservation observeDisparityOffset(const RectifiedStereo& cam, const std::vector<Correspondence>& corr,
                                                  const std::vector<int>& inliers, const RigidMotion& motion,
                                                  const MotionParams& params) {
  DisparityOffsetObservation out;
  using Vector7d = Eigen::Matrix<double, 7, 1>;
  const double sigma = params.pixel_sigma;
  // Gauss-Newton on motion and offset together, to convergence: an offset of a few tenths of a pixel is a tenth of
  // the smallest disparities, too much for one linear step.
  RectifiedStereo at = cam;
  RigidMotion m = motion;
  std::vector<int> use = inliers;
  constexpr int kMaxIterations = 10;
  // The inliers were gated with the offset in use: a wrong one has thrown out the far points that disagree most, and
  // the rest would pull the estimate back towards it. They are gated again at the estimate until they settle.
  constexpr int kMaxRounds = 3;
  for (int round = 0; round < kMaxRounds; ++round) {
    const size_t num_res = use.size() * 3;
    if (num_res <= 7) return out;
    for (int iter = 0; iter <= kMaxIterations; ++iter) {
      Eigen::Matrix<double, 7, 7> jtj = Eigen::Matrix<double, 7, 7>::Zero();
      Vector7d jtr = Vector7d::Zero();
      double chi2 = 0;
      for (int idx : use) {
        Correspondence c = corr[idx];
        c.p_prev = at.triangulate(c.prev.xl, c.prev.y, c.prev.xr);
        const Eigen::Matrix3d cov_prev = at.triangulationCovariance(c.prev.xl, c.prev.y, c.prev.xr, sigma);
        Eigen::Vector3d w, j_offset;
        Eigen::Matrix<double, 3, 6> J6;
        chi2 += whitenedForward(at, c, m.R, m.t, cov_prev, sigma, &w, nullptr, &J6, &j_offset);
        Eigen::Matrix<double, 3, 7> J;
        J << J6, j_offset;
        jtj += J.transpose() * J;
        jtr += J.transpose() * w;
      }
      Eigen::FullPivLU<Eigen::Matrix<double, 7, 7>> lu(jtj);
      if (!lu.isInvertible()) return out;
      const Eigen::Matrix<double, 7, 7> inv = lu.inverse();
      const Vector7d step = -(inv * jtr);
      if (!step.allFinite()) return out;
      if (iter == kMaxIterations || std::abs(step(6)) < 1e-4) {
        out.correction_px = at.disparity_offset - cam.disparity_offset;
        out.variance_px2 = std::max(1.0, chi2 / double(num_res - 7)) * inv(6, 6);
        out.valid = std::isfinite(out.variance_px2) && out.variance_px2 > 0;
        break;
      }
      m.t += step.head<3>();
      m.R = m.R * expSO3(step.segment<3>(3));
      at.disparity_offset += step(6);
    }
    if (!out.valid) return out;
    std::vector<int> again;
    for (size_t i = 0; i < corr.size(); ++i) {
      const Correspondence& c0 = corr[i];
      // Points that the offset moves beyond motion/max_depth stay with the near ones here: the split is the caller's.
      if (c0.prev.xl - c0.prev.xr + at.disparity_offset <= 0) continue;
      Correspondence c = c0;
      c.p_prev = at.triangulate(c.prev.xl, c.prev.y, c.prev.xr);
      const Eigen::Matrix3d cov_prev = at.triangulationCovariance(c.prev.xl, c.prev.y, c.prev.xr, sigma);
      if (whitenedForward(at, c, m.R, m.t, cov_prev, sigma, nullptr, nullptr) < params.inlier_chi2)
        again.push_back(int(i));
    }
    if (again == use || round + 1 == kMaxRounds) break;
    use = std::move(again);
    out.valid = false;
  }
  return out;
}

MotionEstimate estimateMotion(const RectifiedStereo& cam, const std::vector<Correspondence>& corr,
                              const MotionParams& params) {
  MotionEstimate est;
  const int n = int(corr.size());
  if (n < std::max(3, params.min_inliers)) return est;
  const double sigma = params.pixel_sigma;
  const std::vector<Eigen::Matrix3d> cov_prev = prevCovariances(cam, corr, sigma);
  auto collectInliers = [&](const RigidMotion& m, std::vector<int>& inl) {
    inl.clear();
    for (int i = 0; i < n; ++i)
      if (forwardMahalanobis2(cam, corr[i], m, cov_prev[i], sigma) < params.inlier_chi2) inl.push_back(i);
  };

  std::mt19937 rng(params.ransac_seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<int> best_inliers, inliers;
  RigidMotion best;
  int max_iter = params.ransac_iterations;
  std::vector<Eigen::Vector3d> a(3), b(3);
  for (int it = 0; it < max_iter; ++it) {
    int i0 = pick(rng), i1 = pick(rng), i2 = pick(rng);
    if (i0 == i1 || i0 == i2 || i1 == i2) continue;
    a = {corr[i0].p_prev, corr[i1].p_prev, corr[i2].p_prev};
    b = {corr[i0].p_now, corr[i1].p_now, corr[i2].p_now};
    // Nearly collinear samples give a badly conditioned rotation.
    if ((b[1] - b[0]).cross(b[2] - b[0]).norm() < 1e-6) continue;
    RigidMotion m;
    if (!alignPointClouds(a, b, m)) continue;
    collectInliers(m, inliers);
    if (inliers.size() > best_inliers.size()) {
      best_inliers = inliers;
      best = m;
      // Adaptive stop at 99.9 % confidence of one all-inlier sample.
      const double w = double(best_inliers.size()) / n;
      const double p_good = w * w * w;
      if (p_good > 0.999999) break;
      const double needed = std::log(1e-3) / std::log(1.0 - p_good);
      max_iter = std::min(params.ransac_iterations, int(std::ceil(needed)) + 10);
    }
  }
  if (int(best_inliers.size()) < std::max(3, params.min_inliers)) return est;

  // All inliers: closed form, then refined on the reprojection errors; inliers re-collected in between.
  std::vector<Eigen::Vector3d> pa, pb;
  for (int i : best_inliers) {
    pa.push_back(corr[i].p_prev);
    pb.push_back(corr[i].p_now);
  }
  RigidMotion m = best;
  RigidMotion aligned;
  if (alignPointClouds(pa, pb, aligned)) {
    collectInliers(aligned, inliers);
    if (inliers.size() >= best_inliers.size()) {
      m = aligned;
      best_inliers = inliers;
    }
  }
  for (int round = 0; round < 2; ++round) {
    m = refineWithCovariances(cam, corr, cov_prev, best_inliers, m, params.refine_iterations, sigma, nullptr, nullptr);
    collectInliers(m, inliers);
    if (int(inliers.size()) < std::max(3, params.min_inliers)) return est;
    best_inliers = inliers;
  }
  est.motion = refineWithCovariances(cam, corr, cov_prev, best_inliers, m, params.refine_iterations, sigma,
                                     &est.covariance, &est.residual_rms_px);
  est.inliers = best_inliers;
  double s = 0;
  for (int i : best_inliers) s += (corr[i].p_prev - (est.motion.R * corr[i].p_now + est.motion.t)).squaredNorm();
  est.residual_rms_m = std::sqrt(s / double(best_inliers.size()));
  est.valid = int(best_inliers.size()) >= params.min_inliers &&
              double(best_inliers.size()) >= params.min_inlier_ratio * n && est.covariance.allFinite();
  return est;
}

namespace {

// One far correspondence under rotation R: the residual of the older left position (2-D), its whitening and
// the whitened Jacobian by the right perturbation of R.
struct FarResidual {
  Eigen::Vector2d white = Eigen::Vector2d::Zero();
  Eigen::Matrix<double, 2, 3> jac = Eigen::Matrix<double, 2, 3>::Zero();
  double chi2 = 1e12, raw2 = 1e12;
};

FarResidual farResidual(const RectifiedStereo& cam, const Correspondence& c, const Eigen::Matrix3d& R,
                        const Eigen::Vector3d& t, const Eigen::Matrix3d& t_cov, double sigma) {
  FarResidual out;
  const double fb = cam.f * cam.baseline;
  const Eigen::Vector3d a = cam.ray(c.now.xl, c.now.y);
  const double rho = cam.inverseDepth(c.now.xl, c.now.xr);
  const Eigen::Vector3d v = R * a + rho * t;
  if (v.z() < kMinProjectionDepth) return out;
  const Eigen::Vector2d r(c.prev.xl - (cam.f * v.x() / v.z() + cam.cx), c.prev.y - (cam.f * v.y() / v.z() + cam.cy));
  Eigen::Matrix<double, 2, 3> Jv;  // d projection / d v
  Jv << cam.f / v.z(), 0, -cam.f * v.x() / (v.z() * v.z()), 0, cam.f / v.z(), -cam.f * v.y() / (v.z() * v.z());
  // Noise: the older position (sigma), the newer one through a (sigma / f), rho (sqrt(2) sigma / (f b)), t.
  const Eigen::Matrix<double, 2, 3> Ja = Jv * R;
  const Eigen::Vector2d Jrho = Jv * t;
  const Eigen::Matrix<double, 2, 3> Jt = rho * Jv;
  const double s2 = sigma * sigma;
  Eigen::Matrix2d S = s2 * Eigen::Matrix2d::Identity() +
                      (s2 / (cam.f * cam.f)) * Ja.leftCols<2>() * Ja.leftCols<2>().transpose() +
                      (2 * s2 / (fb * fb)) * Jrho * Jrho.transpose() + Jt * t_cov * Jt.transpose();
  Eigen::LLT<Eigen::Matrix2d> llt(S);
  if (llt.info() != Eigen::Success) return out;
  out.white = llt.matrixL().solve(r);
  // v(dr) = R (a + dr x a) + rho t: dv/dr = -R [a]x; the residual is obs - projection.
  out.jac = llt.matrixL().solve(Jv * R * skew(a));
  out.chi2 = out.white.squaredNorm();
  out.raw2 = r.squaredNorm();
  return out;
}

Eigen::Vector3d unitBearing(const RectifiedStereo& cam, const StereoObservation& o) {
  return cam.ray(o.xl, o.y).normalized();
}

}  // namespace

FarRotationEstimate estimateFarRotation(const RectifiedStereo& cam, const std::vector<Correspondence>& far,
                                        const Eigen::Vector3d& t, const Eigen::Matrix3d& t_cov,
                                        const MotionParams& motion, const FarRotationParams& params) {
  FarRotationEstimate est;
  const int n = int(far.size());
  const int min_inliers = std::max(2, params.min_inliers);
  if (n < min_inliers) return est;
  const double sigma = motion.pixel_sigma;
  auto collectInliers = [&](const Eigen::Matrix3d& R, std::vector<int>& inl) {
    inl.clear();
    for (int i = 0; i < n; ++i)
      if (farResidual(cam, far[i], R, t, t_cov, sigma).chi2 < params.inlier_chi2) inl.push_back(i);
  };
  // Wahba's problem on the bearings: R maximising sum b_i . (R a_i), with the older bearing freed of the
  // translation's parallax: R X_now = X_prev - t, so R a ~ a_prev - rho_prev t.
  std::vector<Eigen::Vector3d> prev_bearing(n);
  for (int i = 0; i < n; ++i) {
    const StereoObservation& o = far[i].prev;
    prev_bearing[i] = (cam.ray(o.xl, o.y) - cam.inverseDepth(o.xl, o.xr) * t).normalized();
  }
  auto wahba = [&](const std::vector<int>& use, Eigen::Matrix3d& R) {
    Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
    for (int i : use) B += prev_bearing[i] * unitBearing(cam, far[i].now).transpose();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(B, Eigen::ComputeFullU | Eigen::ComputeFullV);
    if (!(svd.singularValues()(1) > 1e-12)) return false;
    Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
    if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) s(2, 2) = -1;
    R = svd.matrixU() * s * svd.matrixV().transpose();
    return true;
  };

  std::mt19937 rng(motion.ransac_seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<int> best_inliers, inliers;
  Eigen::Matrix3d best = Eigen::Matrix3d::Identity();
  int max_iter = params.ransac_iterations;
  for (int it = 0; it < max_iter; ++it) {
    const int i0 = pick(rng), i1 = pick(rng);
    // Two bearings closer than ~1 deg leave the rotation about them badly conditioned.
    if (unitBearing(cam, far[i0].now).cross(unitBearing(cam, far[i1].now)).norm() < 0.02) continue;
    Eigen::Matrix3d R;
    if (!wahba({i0, i1}, R)) continue;
    collectInliers(R, inliers);
    if (inliers.size() > best_inliers.size()) {
      best_inliers = inliers;
      best = R;
      const double w = double(best_inliers.size()) / n;
      const double p_good = w * w;
      if (p_good > 0.999999) break;
      max_iter = std::min(params.ransac_iterations, int(std::ceil(std::log(1e-3) / std::log(1.0 - p_good))) + 10);
    }
  }
  if (int(best_inliers.size()) < min_inliers) return est;

  // Gauss-Newton on the whitened residuals of the inliers, inliers re-collected after each round.
  Eigen::Matrix3d R = best;
  Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
  double chi2 = 0, raw2 = 0;
  for (int round = 0; round < 3; ++round) {
    for (int iter = 0; iter <= motion.refine_iterations; ++iter) {
      jtj.setZero();
      Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
      chi2 = raw2 = 0;
      for (int i : best_inliers) {
        const FarResidual r = farResidual(cam, far[i], R, t, t_cov, sigma);
        jtj += r.jac.transpose() * r.jac;
        jtr += r.jac.transpose() * r.white;
        chi2 += r.chi2;
        raw2 += r.raw2;
      }
      if (iter == motion.refine_iterations) break;
      const Eigen::Vector3d delta = jtj.ldlt().solve(-jtr);
      if (!delta.allFinite()) break;
      R = R * expSO3(delta);
      if (delta.norm() < 1e-12) break;
    }
    collectInliers(R, inliers);
    if (int(inliers.size()) < min_inliers) return est;
    if (inliers == best_inliers) break;
    best_inliers = inliers;
  }
  // The covariance at the final rotation and inlier set.
  jtj.setZero();
  chi2 = raw2 = 0;
  for (int i : best_inliers) {
    const FarResidual r = farResidual(cam, far[i], R, t, t_cov, sigma);
    jtj += r.jac.transpose() * r.jac;
    chi2 += r.chi2;
    raw2 += r.raw2;
  }
  const double dof = std::max(1.0, 2.0 * double(best_inliers.size()) - 3.0);
  est.R = R;
  est.covariance = std::max(1.0, chi2 / dof) * jtj.inverse();
  est.inliers = best_inliers;
  est.residual_rms_px = std::sqrt(raw2 / (2.0 * double(best_inliers.size())));
  est.valid = double(best_inliers.size()) >= motion.min_inlier_ratio * n && est.covariance.allFinite();
  return est;
}

}  // namespace ips::tracker
