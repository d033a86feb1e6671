// Motion stage on synthetic correspondences with a known motion: closed-form alignment, RANSAC with
// outliers, refinement and the covariance's consistency with the actual errors.
#include <gtest/gtest.h>

#include <random>

#include "ips/tracker/motion.hpp"

using namespace ips::tracker;

namespace {

RectifiedStereo testStereo() {
  RectifiedStereo s;
  s.f = 500;
  s.cx = 320;
  s.cy = 240;
  s.baseline = 0.12;
  return s;
}

RigidMotion trueMotion() {
  RigidMotion m;
  m.R = expSO3(Eigen::Vector3d(0.05, -0.1, 0.03));
  m.t = Eigen::Vector3d(0.2, -0.05, 0.3);
  return m;
}

// Points seen by both pairs; observations with pixel noise, then triangulated from the noisy pixels as the
// tracker does. The first `outliers` correspondences get a random newer observation.
std::vector<Correspondence> makeCorrespondences(const RectifiedStereo& cam, const RigidMotion& m, int count,
                                                double noise_px, int outliers, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0, 640), uy(0, 480), uz(2, 20);
  std::normal_distribution<double> noise(0, noise_px);
  std::vector<Correspondence> out;
  while (int(out.size()) < count) {
    const double z = uz(rng);
    const Eigen::Vector3d p_prev((ux(rng) - cam.cx) * z / cam.f, (uy(rng) - cam.cy) * z / cam.f, z);
    const Eigen::Vector3d p_now = m.R.transpose() * (p_prev - m.t);
    if (p_now.z() < 1.0) continue;
    const Eigen::Vector3d a = cam.project(p_prev), b = cam.project(p_now);
    if (b(0) < 0 || b(0) > 640 || b(1) < 0 || b(1) > 480) continue;
    Correspondence c;
    c.prev = {a(0) + noise(rng), a(1) + noise(rng), a(2) + noise(rng)};
    c.now = {b(0) + noise(rng), b(1) + noise(rng), b(2) + noise(rng)};
    if (int(out.size()) < outliers) {
      const double d = c.now.xl - c.now.xr;
      c.now.xl = ux(rng);
      c.now.y = uy(rng);
      c.now.xr = c.now.xl - d;
    }
    c.p_prev = cam.triangulate(c.prev.xl, c.prev.y, c.prev.xr);
    c.p_now = cam.triangulate(c.now.xl, c.now.y, c.now.xr);
    out.push_back(c);
  }
  return out;
}

double rotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return logSO3(a.transpose() * b).norm() * 180.0 / M_PI;
}

}  // namespace

TEST(Motion, TriangulateProjectRoundTrip) {
  const RectifiedStereo cam = testStereo();
  const Eigen::Vector3d p(0.7, -0.3, 4.2);
  const Eigen::Vector3d uv = cam.project(p);
  EXPECT_NEAR(uv(0) - uv(2), cam.f * cam.baseline / p.z(), 1e-9);  // disparity = f B / Z
  EXPECT_LT((cam.triangulate(uv(0), uv(1), uv(2)) - p).norm(), 1e-9);
}

TEST(Motion, AlignPointCloudsIsExactWithoutNoise) {
  const RigidMotion m = trueMotion();
  std::vector<Eigen::Vector3d> prev, now;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-5, 5);
  for (int i = 0; i < 10; ++i) {
    now.emplace_back(u(rng), u(rng), u(rng) + 10);
    prev.push_back(m.R * now.back() + m.t);
  }
  RigidMotion est;
  ASSERT_TRUE(alignPointClouds(prev, now, est));
  EXPECT_LT(rotationErrorDeg(est.R, m.R), 1e-8);
  EXPECT_LT((est.t - m.t).norm(), 1e-9);
  EXPECT_NEAR(est.R.determinant(), 1.0, 1e-12);
}

TEST(Motion, AlignPointCloudsRejectsCollinearPoints) {
  std::vector<Eigen::Vector3d> line = {{0, 0, 1}, {1, 1, 2}, {2, 2, 3}, {3, 3, 4}};
  RigidMotion est;
  EXPECT_FALSE(alignPointClouds(line, line, est));
  EXPECT_FALSE(alignPointClouds({{0, 0, 1}, {1, 0, 1}}, {{0, 0, 1}, {1, 0, 1}}, est));
}

TEST(Motion, RansacFindsMotionDespiteThirtyPercentOutliers) {
  const RectifiedStereo cam = testStereo();
  const RigidMotion m = trueMotion();
  const int count = 300, outliers = 90;
  const auto corr = makeCorrespondences(cam, m, count, 0.2, outliers, 7);
  MotionParams params;
  const MotionEstimate est = estimateMotion(cam, corr, params);
  ASSERT_TRUE(est.valid);
  EXPECT_LT(rotationErrorDeg(est.motion.R, m.R), 0.05);
  EXPECT_LT((est.motion.t - m.t).norm(), 0.005);
  int outliers_kept = 0;
  for (int i : est.inliers) outliers_kept += i < outliers;
  EXPECT_LE(outliers_kept, 2);  // a random outlier may fall within the threshold by chance
  EXPECT_GE(int(est.inliers.size()) - outliers_kept, int(0.95 * (count - outliers)));
  // Raw image rms includes far points' depth noise carried through the motion: a few noise sigmas.
  EXPECT_LT(est.residual_rms_px, 1.0);
}

TEST(Motion, CovarianceMatchesActualErrors) {
  // Normalised estimation error squared over independent noise draws: mean 6 for a consistent covariance.
  const RectifiedStereo cam = testStereo();
  const RigidMotion m = trueMotion();
  MotionParams params;
  double nees = 0;
  const int runs = 40;
  for (int r = 0; r < runs; ++r) {
    const auto corr = makeCorrespondences(cam, m, 80, 0.3, 0, 100 + r);
    const MotionEstimate est = estimateMotion(cam, corr, params);
    ASSERT_TRUE(est.valid);
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = m.t - est.motion.t;
    e.tail<3>() = logSO3(est.motion.R.transpose() * m.R);
    nees += e.dot(est.covariance.ldlt().solve(e));
  }
  nees /= runs;
  EXPECT_GT(nees, 6.0 / 2.5);
  EXPECT_LT(nees, 6.0 * 2.5);
}

TEST(Motion, TooFewCorrespondencesAreInvalid) {
  const RectifiedStereo cam = testStereo();
  const auto corr = makeCorrespondences(cam, trueMotion(), 8, 0.1, 0, 3);
  MotionParams params;  // min_inliers 12
  EXPECT_FALSE(estimateMotion(cam, corr, params).valid);
  EXPECT_FALSE(estimateMotion(cam, {}, params).valid);
}

TEST(Motion, AllOutliersAreInvalid) {
  const RectifiedStereo cam = testStereo();
  const auto corr = makeCorrespondences(cam, trueMotion(), 100, 0.1, 100, 5);
  MotionParams params;
  EXPECT_FALSE(estimateMotion(cam, corr, params).valid);
}
