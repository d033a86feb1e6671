#include "ips/filter/kalman.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

#include "ips/filter/optional_states.hpp"

namespace ips::filter {

// ---------------------------------------------------------------------------------------------- common

void KalmanFilter::reset(const FullState& x, const Eigen::MatrixXd& P) {
  if (P.rows() != x.errorDim() || P.cols() != x.errorDim())
    throw std::invalid_argument("KalmanFilter::reset: covariance size does not match the state");
  if (!P.allFinite()) throw std::invalid_argument("KalmanFilter::reset: covariance is not finite");
  x_ = x;
  P_ = P;
  symmetrize();
}

void KalmanFilter::symmetrize() { P_ = 0.5 * (P_ + P_.transpose()).eval(); }

int KalmanFilter::addClone() {
  const int n = x_.errorDim();
  PoseClone c;
  c.utime = x_.nav.utime;
  c.position = x_.nav.position;
  c.orientation = x_.nav.orientation;
  x_.clones.push_back(c);
  // The clone's error equals the current position and attitude error: P' = J P J^T, J = [I; S].
  Eigen::MatrixXd P(n + kCloneErrorDim, n + kCloneErrorDim);
  P.topLeftCorner(n, n) = P_;
  const int sel[6] = {kErrP, kErrP + 1, kErrP + 2, kErrTh, kErrTh + 1, kErrTh + 2};
  for (int i = 0; i < 6; ++i) P.row(n + i).head(n) = P_.row(sel[i]);
  for (int i = 0; i < 6; ++i) P.col(n + i).head(n) = P_.col(sel[i]);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) P(n + i, n + j) = P_(sel[i], sel[j]);
  P_ = std::move(P);
  return static_cast<int>(x_.clones.size()) - 1;
}

std::unique_ptr<KalmanFilter> KalmanFilter::copyWithoutClones(int keep) const {
  std::unique_ptr<KalmanFilter> c = copy();
  const int core = x_.cloneOffset(0);
  c->x_.clones.clear();
  if (keep < 0 || keep >= static_cast<int>(x_.clones.size())) {
    c->P_ = P_.topLeftCorner(core, core);
    return c;
  }
  c->x_.clones.push_back(x_.clones[keep]);
  const int o = x_.cloneOffset(keep);
  Eigen::MatrixXd P(core + kCloneErrorDim, core + kCloneErrorDim);
  P.topLeftCorner(core, core) = P_.topLeftCorner(core, core);
  P.topRightCorner(core, kCloneErrorDim) = P_.block(0, o, core, kCloneErrorDim);
  P.bottomLeftCorner(kCloneErrorDim, core) = P_.block(o, 0, kCloneErrorDim, core);
  P.bottomRightCorner(kCloneErrorDim, kCloneErrorDim) = P_.block(o, o, kCloneErrorDim, kCloneErrorDim);
  c->P_ = std::move(P);
  return c;
}

void KalmanFilter::removeClone(int index) {
  if (index < 0 || index >= static_cast<int>(x_.clones.size()))
    throw std::out_of_range("KalmanFilter::removeClone: no such clone");
  const int n = x_.errorDim();
  const int o = x_.cloneOffset(index);
  const int tail = n - o - kCloneErrorDim;
  Eigen::MatrixXd P(n - kCloneErrorDim, n - kCloneErrorDim);
  P.topLeftCorner(o, o) = P_.topLeftCorner(o, o);
  P.topRightCorner(o, tail) = P_.topRightCorner(o, tail);
  P.bottomLeftCorner(tail, o) = P_.bottomLeftCorner(tail, o);
  P.bottomRightCorner(tail, tail) = P_.bottomRightCorner(tail, tail);
  P_ = std::move(P);
  x_.clones.erase(x_.clones.begin() + index);
}

void KalmanFilter::resetErrorBlock(int offset, int size, double variance) {
  if (offset < 0 || size < 0 || offset + size > P_.rows()) throw std::out_of_range("resetErrorBlock: bad range");
  P_.middleRows(offset, size).setZero();
  P_.middleCols(offset, size).setZero();
  P_.diagonal().segment(offset, size).setConstant(variance);
}

void KalmanFilter::addRandomWalks(double dt, const ProcessNoise& q) {
  forEachOptionalState([&](const auto& spec) {
    if (spec.random_walk_psd && x_.*spec.value)
      P_.diagonal().segment(x_.offset(spec.id), spec.kDim).array() += q.*spec.random_walk_psd * dt;
  });
}

// ---------------------------------------------------------------------------------------------- EKF

void ExtendedKalmanFilter::predict(double dt, const ProcessNoise& q) {
  if (!(dt >= 0)) throw std::invalid_argument("predict: negative time step");
  if (dt == 0) return;
  const Matrix21d F = processJacobian(x_.nav, dt);
  x_.nav = propagateNav(x_.nav, dt);
  const int n = x_.errorDim();
  const int nc = n - kCoreErrorDim;
  const Matrix21d Pxx = P_.topLeftCorner<kCoreErrorDim, kCoreErrorDim>();
  P_.topLeftCorner<kCoreErrorDim, kCoreErrorDim>() = F * Pxx * F.transpose() + processNoise(x_.nav, dt, q);
  if (nc > 0) {
    const Eigen::MatrixXd Pxc = F * P_.topRightCorner(kCoreErrorDim, nc);
    P_.topRightCorner(kCoreErrorDim, nc) = Pxc;
    P_.bottomLeftCorner(nc, kCoreErrorDim) = Pxc.transpose();
  }
  addRandomWalks(dt, q);
}

UpdateResult ExtendedKalmanFilter::update(const Measurement& m, double gate) {
  UpdateResult res;
  const MeasVector r = m.residual(x_);
  const Eigen::MatrixXd H = m.jacobian(x_);
  const Eigen::MatrixXd PHt = P_ * H.transpose();
  const Eigen::MatrixXd S = H * PHt + m.noise();
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) return res;
  res.mahalanobis2 = r.dot(llt.solve(r));
  if (!(res.mahalanobis2 <= gate)) return res;
  const Eigen::MatrixXd K = llt.solve(PHt.transpose()).transpose();
  const Eigen::VectorXd dx = K * r;
  boxplusInto(x_, dx, x_);
  P_.noalias() -= K * PHt.transpose();
  symmetrize();
  res.applied = true;
  return res;
}

// ---------------------------------------------------------------------------------------------- UKF

UnscentedKalmanFilter::Weights UnscentedKalmanFilter::weights(int n) const {
  Weights w;
  const double a = params_.ukf_alpha;
  w.lambda = a * a * (n + params_.ukf_kappa) - n;
  const double nl = n + w.lambda;
  if (!(nl > 0)) throw std::invalid_argument("UKF: alpha^2 (n + kappa) must be positive");
  w.mean0 = w.lambda / nl;
  w.cov0 = w.mean0 + 1.0 - a * a + params_.ukf_beta;
  w.other = 0.5 / nl;
  w.spread = std::sqrt(nl);
  return w;
}

Eigen::MatrixXd UnscentedKalmanFilter::choleskyLower() {
  for (int attempt = 0; attempt < 4; ++attempt) {
    Eigen::LLT<Eigen::MatrixXd> llt(P_);
    if (llt.info() == Eigen::Success) return llt.matrixL();
    P_.diagonal().array() += 1e-12 * std::pow(100.0, attempt) * std::max(1.0, P_.diagonal().maxCoeff());
  }
  throw std::runtime_error("UKF: covariance is not positive definite");
}

Eigen::MatrixXd UnscentedKalmanFilter::choleskyCoreColumns() {
  const int n = x_.errorDim();
  Eigen::MatrixXd L(n, kCoreErrorDim);
  for (int attempt = 0; attempt < 4; ++attempt) {
    Eigen::LLT<Matrix21d> llt(P_.topLeftCorner<kCoreErrorDim, kCoreErrorDim>());
    if (llt.info() == Eigen::Success) {
      L.topRows<kCoreErrorDim>() = llt.matrixL();
      if (n > kCoreErrorDim)
        L.bottomRows(n - kCoreErrorDim) =
            llt.matrixL().solve(P_.bottomLeftCorner(n - kCoreErrorDim, kCoreErrorDim).transpose()).transpose();
      return L;
    }
    P_.diagonal().array() += 1e-12 * std::pow(100.0, attempt) * std::max(1.0, P_.diagonal().maxCoeff());
  }
  throw std::runtime_error("UKF: covariance is not positive definite");
}

void UnscentedKalmanFilter::predict(double dt, const ProcessNoise& q) {
  if (!(dt >= 0)) throw std::invalid_argument("predict: negative time step");
  if (dt == 0) return;
  const int n = x_.errorDim();
  const int nc = n - kCoreErrorDim;
  const Weights w = weights(n);
  const Eigen::MatrixXd L = choleskyCoreColumns();
  // Only the first 21 Cholesky columns move the navigation state (L is lower triangular); the process does
  // not change the lever arm or the clones, so the sigma points of the other columns map exactly and need no
  // evaluation.
  const NavState ref = propagateNav(x_.nav, dt);
  Eigen::Matrix<double, kCoreErrorDim, 2 * kCoreErrorDim> E;
  for (int j = 0; j < kCoreErrorDim; ++j) {
    const Vector21d d = w.spread * L.col(j).head<kCoreErrorDim>();
    E.col(2 * j) = boxminus(propagateNav(boxplus(x_.nav, d), dt), ref);
    E.col(2 * j + 1) = boxminus(propagateNav(boxplus(x_.nav, (-d).eval()), dt), ref);
  }
  const Vector21d mean = w.other * E.rowwise().sum();
  x_.nav = boxplus(ref, mean);
  E.colwise() -= mean;
  Matrix21d Pxx = w.other * E * E.transpose();
  Pxx += (w.cov0 + 2.0 * (n - kCoreErrorDim) * w.other) * mean * mean.transpose();
  Pxx += processNoise(x_.nav, dt, q);
  P_.topLeftCorner<kCoreErrorDim, kCoreErrorDim>() = Pxx;
  if (nc > 0) {
    // Lever-arm and clone deviations of the sigma points are +-spread * L(their rows, j).
    Matrix21d Ediff;
    for (int j = 0; j < kCoreErrorDim; ++j) Ediff.col(j) = E.col(2 * j) - E.col(2 * j + 1);
    const Eigen::MatrixXd Pxc = (w.other * w.spread) * Ediff * L.bottomRows(nc).transpose();
    P_.topRightCorner(kCoreErrorDim, nc) = Pxc;
    P_.bottomLeftCorner(nc, kCoreErrorDim) = Pxc.transpose();
  }
  addRandomWalks(dt, q);
  symmetrize();
}

UpdateResult UnscentedKalmanFilter::update(const Measurement& m, double gate) {
  UpdateResult res;
  const int n = x_.errorDim();
  const int md = m.dim();
  const Weights w = weights(n);
  const int cols = m.coreOnly() ? kCoreErrorDim : n;
  const Eigen::MatrixXd L = m.coreOnly() ? choleskyCoreColumns() : choleskyLower();

  const MeasVector r0 = m.residual(x_);
  Eigen::MatrixXd Rp(md, cols), Rm(md, cols);
  scratch_ = x_;
  Eigen::VectorXd d(n);
  for (int j = 0; j < cols; ++j) {
    for (int s = 0; s < 2; ++s) {
      d = (s == 0 ? w.spread : -w.spread) * L.col(j);
      if (m.coreOnly())
        scratch_.nav = boxplus(x_.nav, d.head<kCoreErrorDim>());
      else
        boxplusInto(x_, d, scratch_);
      (s == 0 ? Rp : Rm).col(j) = m.residual(scratch_);
    }
  }
  // Columns not evaluated leave h unchanged: their residual is r0.
  const double w_rest = 2.0 * (n - cols) * w.other;
  const MeasVector rbar = w.mean0 * r0 + w.other * (Rp.rowwise().sum() + Rm.rowwise().sum()) + w_rest * r0;
  Eigen::MatrixXd Dp = Rp.colwise() - rbar, Dm = Rm.colwise() - rbar;
  const MeasVector d0 = r0 - rbar;
  Eigen::MatrixXd Pzz = w.other * (Dp * Dp.transpose() + Dm * Dm.transpose());
  Pzz += (w.cov0 + w_rest) * d0 * d0.transpose();
  Pzz += m.noise();
  // Cross covariance of state and predicted measurement; h = z - r, so the sign flips.
  const Eigen::MatrixXd Pxz = -(w.other * w.spread) * L.leftCols(cols) * (Rp - Rm).transpose();

  const Eigen::LLT<Eigen::MatrixXd> llt(Pzz);
  if (llt.info() != Eigen::Success) return res;
  res.mahalanobis2 = rbar.dot(llt.solve(rbar));
  if (!(res.mahalanobis2 <= gate)) return res;
  const Eigen::MatrixXd K = llt.solve(Pxz.transpose()).transpose();
  const Eigen::VectorXd dx = K * rbar;
  boxplusInto(x_, dx, x_);
  P_.noalias() -= K * Pzz * K.transpose();
  symmetrize();
  res.applied = true;
  return res;
}

std::unique_ptr<KalmanFilter> makeKalmanFilter(const FilterParams& params) {
  if (params.type == FilterType::Ukf) return std::make_unique<UnscentedKalmanFilter>(params);
  return std::make_unique<ExtendedKalmanFilter>(params);
}

}  // namespace ips::filter
