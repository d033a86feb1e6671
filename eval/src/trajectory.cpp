#include "ips/eval/trajectory.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "ips/rotation.hpp"

namespace ips::eval {

// The filter's state layout and error-state helpers (NEES).
using namespace ips::filter;

Trajectory readTum(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  Trajectory traj;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    TrajPoint p;
    double qx, qy, qz, qw;
    if (!(ss >> p.t >> p.p.x() >> p.p.y() >> p.p.z() >> qx >> qy >> qz >> qw))
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": expected 't tx ty tz qx qy qz qw'");
    p.q = Eigen::Quaterniond(qw, qx, qy, qz);
    if (std::abs(p.q.norm() - 1.0) > 1e-2)
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": quaternion is not unit");
    p.q.normalize();
    if (!traj.empty() && p.t <= traj.back().t)
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": time stamps must increase");
    traj.push_back(p);
  }
  return traj;
}

void writeTum(const std::string& path, const Trajectory& traj) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << "# t tx ty tz qx qy qz qw\n" << std::fixed;
  for (const TrajPoint& p : traj)
    out << std::setprecision(6) << p.t << ' ' << std::setprecision(6) << p.p.x() << ' ' << p.p.y() << ' ' << p.p.z()
        << ' ' << std::setprecision(9) << p.q.x() << ' ' << p.q.y() << ' ' << p.q.z() << ' ' << p.q.w() << '\n';
}

void associate(const Trajectory& est, const Trajectory& ref, double max_gap_s, Trajectory* est_out,
               Trajectory* ref_out) {
  est_out->clear();
  ref_out->clear();
  size_t j = 0;
  for (const TrajPoint& e : est) {
    while (j + 1 < ref.size() && ref[j + 1].t < e.t) ++j;
    if (j + 1 >= ref.size() || e.t < ref[j].t) continue;
    const TrajPoint& a = ref[j];
    const TrajPoint& b = ref[j + 1];
    if (b.t - a.t > 2 * max_gap_s && std::min(e.t - a.t, b.t - e.t) > max_gap_s) continue;
    const double s = (b.t > a.t) ? (e.t - a.t) / (b.t - a.t) : 0.0;
    TrajPoint r;
    r.t = e.t;
    r.p = (1 - s) * a.p + s * b.p;
    r.q = a.q.slerp(s, b.q);
    est_out->push_back(e);
    ref_out->push_back(r);
  }
}

Eigen::Isometry3d alignSE3(const Trajectory& est, const Trajectory& ref) {
  if (est.size() != ref.size() || est.size() < 3) throw std::invalid_argument("alignSE3: need >= 3 matched points");
  Eigen::Vector3d me = Eigen::Vector3d::Zero(), mr = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < est.size(); ++i) {
    me += est[i].p;
    mr += ref[i].p;
  }
  me /= static_cast<double>(est.size());
  mr /= static_cast<double>(est.size());
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < est.size(); ++i) C += (ref[i].p - mr) * (est[i].p - me).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) S(2, 2) = -1;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = svd.matrixU() * S * svd.matrixV().transpose();
  T.translation() = mr - T.linear() * me;
  return T;
}

double distanceTravelled(const Trajectory& traj) {
  double distance = 0;
  for (size_t i = 1; i < traj.size(); ++i) distance += (traj[i].p - traj[i - 1].p).norm();
  return distance;
}

double ateRmse(const Trajectory& est, const Trajectory& ref) {
  const Eigen::Isometry3d T = alignSE3(est, ref);
  double se = 0;
  for (size_t i = 0; i < est.size(); ++i) se += (T * est[i].p - ref[i].p).squaredNorm();
  return std::sqrt(se / static_cast<double>(est.size()));
}

TrajectoryErrors evaluate(const Trajectory& est, const Trajectory& ref, double segment_m) {
  if (est.size() != ref.size() || est.size() < 3) throw std::invalid_argument("evaluate: need >= 3 matched points");
  TrajectoryErrors e;
  e.matched = est.size();
  std::vector<double> dist(ref.size(), 0.0);
  for (size_t i = 1; i < ref.size(); ++i) dist[i] = dist[i - 1] + (ref[i].p - ref[i - 1].p).norm();
  e.distance_m = dist.back();
  e.ate_rmse_m = ateRmse(est, ref);
  e.endpoint_error_m = (est.back().p - ref.back().p).norm();
  e.endpoint_percent = e.distance_m > 0 ? 100.0 * e.endpoint_error_m / e.distance_m : 0.0;
  // Relative error: for each start, the first sample at least segment_m further along the reference.
  double sum = 0;
  int count = 0;
  size_t j = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    j = std::max(j, i);
    while (j < ref.size() && dist[j] - dist[i] < segment_m) ++j;
    if (j >= ref.size()) break;
    const Eigen::Vector3d dr = ref[i].q.conjugate() * (ref[j].p - ref[i].p);
    const Eigen::Vector3d de = est[i].q.conjugate() * (est[j].p - est[i].p);
    sum += (de - dr).norm() / (dist[j] - dist[i]);
    ++count;
  }
  e.rpe_percent = count > 0 ? 100.0 * sum / count : 0.0;
  return e;
}

namespace {
Eigen::Isometry3d toIso(const TrajPoint& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = p.q.normalized().toRotationMatrix();
  T.translation() = p.p;
  return T;
}
}  // namespace

RelativeErrors relativeErrors(const Trajectory& est, const Trajectory& ref, const std::vector<double>& lengths_m) {
  if (est.size() != ref.size()) throw std::invalid_argument("relativeErrors: trajectories not associated");
  RelativeErrors r;
  std::vector<double> dist(ref.size(), 0.0);
  for (size_t i = 1; i < ref.size(); ++i) dist[i] = dist[i - 1] + (ref[i].p - ref[i - 1].p).norm();
  double t_sum = 0, r_sum = 0;
  for (double len : lengths_m) {
    bool any = false;
    size_t j = 0;
    for (size_t i = 0; i < ref.size(); ++i) {
      j = std::max(j, i);
      while (j < ref.size() && dist[j] - dist[i] < len) ++j;
      if (j >= ref.size()) break;
      const Eigen::Isometry3d d_ref = toIso(ref[i]).inverse() * toIso(ref[j]);
      const Eigen::Isometry3d d_est = toIso(est[i]).inverse() * toIso(est[j]);
      const Eigen::Isometry3d E = d_est.inverse() * d_ref;
      t_sum += E.translation().norm() / len;
      r_sum += Eigen::AngleAxisd(E.linear()).angle() * 180.0 / M_PI / len;
      ++r.subsequences;
      any = true;
    }
    r.lengths += any ? 1 : 0;
  }
  if (r.subsequences > 0) {
    r.trans_pct = 100.0 * t_sum / static_cast<double>(r.subsequences);
    r.rot_deg_per_m = r_sum / static_cast<double>(r.subsequences);
  }
  return r;
}

std::vector<PositionStep> removePositionSteps(Trajectory& truth, double max_acceleration) {
  // Residual i: increment i (sample i to i + 1) less the mean of increments i - 1 and i + 1 (scaled by the
  // intervals). A step in increment i gives s there and -s/2 beside it, so a step is a residual above the threshold
  // and above both of its neighbours'.
  const size_t n = truth.size();
  std::vector<Eigen::Vector3d> residual(n, Eigen::Vector3d::Zero());
  std::vector<bool> judged(n, false);
  for (size_t i = 1; i + 2 < n; ++i) {
    const double dt_before = truth[i].t - truth[i - 1].t, dt = truth[i + 1].t - truth[i].t,
                 dt_after = truth[i + 2].t - truth[i + 1].t;
    if (!(dt_before > 0 && dt > 0 && dt_after > 0) || dt > 2 * std::min(dt_before, dt_after) ||
        dt < 0.5 * std::max(dt_before, dt_after))
      continue;
    const Eigen::Vector3d expected =
        0.5 * ((truth[i].p - truth[i - 1].p) / dt_before + (truth[i + 2].p - truth[i + 1].p) / dt_after) * dt;
    residual[i] = (truth[i + 1].p - truth[i].p) - expected;
    judged[i] = residual[i].norm() > max_acceleration * dt * dt;
  }
  std::vector<PositionStep> steps;
  for (size_t i = 1; i + 2 < n; ++i)
    if (judged[i] && residual[i].norm() >= residual[i - 1].norm() && residual[i].norm() >= residual[i + 1].norm())
      steps.push_back({truth[i + 1].t, residual[i]});
  size_t next = 0;
  Eigen::Vector3d removed = Eigen::Vector3d::Zero();
  for (auto& point : truth) {
    while (next < steps.size() && steps[next].t <= point.t) removed += steps[next++].step;
    point.p -= removed;
  }
  return steps;
}

Trajectory alignFirstPose(const Trajectory& est, const Trajectory& ref) {
  if (est.empty() || ref.empty()) return est;
  const Eigen::Isometry3d T = toIso(ref.front()) * toIso(est.front()).inverse();
  Trajectory out = est;
  const Eigen::Quaterniond qT(T.linear());
  for (auto& p : out) {
    p.p = T * p.p;
    p.q = (qT * p.q).normalized();
  }
  return out;
}

double endErrorFirstPoseAligned(const Trajectory& est, const Trajectory& ref) {
  if (est.size() != ref.size() || est.empty()) throw std::invalid_argument("endErrorFirstPoseAligned: not associated");
  return (alignFirstPose(est, ref).back().p - ref.back().p).norm();
}

double poseNees(const FilterOutput& out, const NavState& truth) {
  Vector6d err;
  err.head<3>() = truth.position - out.state.position;
  err.tail<3>() = logQuat(truth.orientation * out.state.orientation.conjugate());
  Matrix6d P;
  const int idx[6] = {kErrP, kErrP + 1, kErrP + 2, kErrTh, kErrTh + 1, kErrTh + 2};
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) P(i, j) = out.covariance(idx[i], idx[j]);
  return err.dot(P.ldlt().solve(err));
}

double fullNees(const FilterOutput& out, const NavState& truth) {
  const Vector21d err = boxminus(truth, out.state);
  return err.dot(out.covariance.ldlt().solve(err));
}

Trajectory toTrajectory(const std::vector<FilterOutput>& outputs) {
  Trajectory t;
  t.reserve(outputs.size());
  for (const FilterOutput& o : outputs) t.push_back({o.state.utime * 1e-6, o.state.position, o.state.orientation});
  return t;
}

void plotTopDown(const std::string& path, const Trajectory& ref, const std::vector<Trajectory>& estimates,
                 const std::vector<std::string>& labels) {
  const int size = 900, margin = 60;
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  auto grow = [&](const Trajectory& t) {
    for (const TrajPoint& p : t) {
      xmin = std::min(xmin, p.p.x()), xmax = std::max(xmax, p.p.x());
      ymin = std::min(ymin, p.p.y()), ymax = std::max(ymax, p.p.y());
    }
  };
  grow(ref);
  for (const Trajectory& t : estimates) grow(t);
  if (xmin > xmax) throw std::invalid_argument("plotTopDown: nothing to plot");
  const double span = std::max({xmax - xmin, ymax - ymin, 1e-3});
  const double scale = (size - 2 * margin) / span;
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(255, 255, 255));
  auto px = [&](const Eigen::Vector3d& p) {
    return cv::Point(static_cast<int>(margin + (p.x() - xmin) * scale),
                     static_cast<int>(size - margin - (p.y() - ymin) * scale));
  };
  auto draw = [&](const Trajectory& t, const cv::Scalar& colour) {
    for (size_t i = 1; i < t.size(); ++i) cv::line(img, px(t[i - 1].p), px(t[i].p), colour, 2, cv::LINE_AA);
  };
  const cv::Scalar colours[] = {{0, 0, 220}, {220, 0, 0}, {0, 160, 0}, {200, 0, 200}};
  draw(ref, cv::Scalar(0, 0, 0));
  cv::putText(img, "ground truth", cv::Point(10, 20), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 1);
  for (size_t k = 0; k < estimates.size(); ++k) {
    draw(estimates[k], colours[k % 4]);
    cv::putText(img, k < labels.size() ? labels[k] : "estimate", cv::Point(10, 45 + 25 * static_cast<int>(k)),
                cv::FONT_HERSHEY_SIMPLEX, 0.6, colours[k % 4], 1);
  }
  std::ostringstream scale_text;
  scale_text << "x-y, " << std::fixed << std::setprecision(1) << span << " m across";
  cv::putText(img, scale_text.str(), cv::Point(10, size - 15), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(80, 80, 80),
              1);
  if (!cv::imwrite(path, img)) throw std::runtime_error(path + ": cannot write PNG");
}

TrajPoint interpolate(const Trajectory& traj, double t) {
  if (traj.empty()) throw std::invalid_argument("interpolate: empty trajectory");
  auto it = std::lower_bound(traj.begin(), traj.end(), t, [](const TrajPoint& a, double v) { return a.t < v; });
  if (it == traj.begin()) return traj.front();
  if (it == traj.end()) return traj.back();
  const TrajPoint& a = *(it - 1);
  const double w = (t - a.t) / std::max(1e-12, it->t - a.t);
  TrajPoint p;
  p.t = t;
  p.p = a.p + w * (it->p - a.p);
  p.q = a.q.slerp(w, it->q);
  return p;
}

Trajectory rigidlyAttached(const Trajectory& traj, const Eigen::Isometry3d& T_a_b) {
  Trajectory out;
  out.reserve(traj.size());
  for (const TrajPoint& a : traj) {
    const Eigen::Isometry3d T = toIso(a) * T_a_b;
    TrajPoint b;
    b.t = a.t;
    b.p = T.translation();
    b.q = Eigen::Quaterniond(T.linear());
    out.push_back(b);
  }
  return out;
}

DeltaConsistency deltaConsistency(const std::vector<RelativePoseMeasurement>& deltas, const Trajectory& truth) {
  DeltaConsistency c;
  if (truth.size() < 2) return c;
  auto poseAt = [&truth](double t) { return toIso(interpolate(truth, t)); };
  std::vector<Eigen::Vector3d> errors;
  double sum_t = 0, sum_r = 0;
  for (const auto& d : deltas) {
    if (d.t0 < truth.front().t || d.t1 > truth.back().t) continue;
    const Eigen::Isometry3d T_truth = poseAt(d.t0).inverse() * poseAt(d.t1);
    const Eigen::Vector3d e_t = d.T.translation() - T_truth.translation();
    const Eigen::Vector3d e_r = ips::logSO3(d.T.linear() * T_truth.linear().transpose());
    sum_t += e_t.dot(d.covariance.topLeftCorner<3, 3>().ldlt().solve(e_t));
    sum_r += e_r.dot(d.covariance.bottomRightCorner<3, 3>().ldlt().solve(e_r));
    errors.push_back(e_t);
  }
  c.deltas = static_cast<int>(errors.size());
  if (c.deltas == 0) return c;
  c.nees_translation = sum_t / c.deltas;
  c.nees_rotation = sum_r / c.deltas;
  if (c.deltas >= 3) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& e : errors) mean += e / c.deltas;
    double cov1 = 0, var = 0;
    for (size_t i = 0; i < errors.size(); ++i) {
      var += (errors[i] - mean).squaredNorm();
      if (i + 1 < errors.size()) cov1 += (errors[i] - mean).dot(errors[i + 1] - mean);
    }
    c.lag1_correlation = var > 0 ? cov1 / var : NAN;
  }
  return c;
}

}  // namespace ips::eval
