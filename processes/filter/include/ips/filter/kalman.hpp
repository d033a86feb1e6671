#pragma once
// The two filters behind one interface: an error-state Extended Kalman filter with analytic Jacobians and a
// scaled Unscented Kalman filter (Julier 2002) that only evaluates the model functions. Both hold the same
// mean (FullState: navigation state, the lever arm when estimated, pose clones) and the covariance of its error state.
#include <Eigen/Core>
#include <memory>

#include "ips/filter/models.hpp"
#include "ips/filter/params.hpp"
#include "ips/filter/state.hpp"

namespace ips::filter {

struct UpdateResult {
  bool applied = false;
  double mahalanobis2 = 0;  // squared Mahalanobis distance of the innovation
};

class KalmanFilter {
 public:
  virtual ~KalmanFilter() = default;
  virtual FilterType type() const = 0;

  void reset(const FullState& x, const Eigen::MatrixXd& P);
  const FullState& state() const { return x_; }
  const Eigen::MatrixXd& covariance() const { return P_; }

  // Time update over dt >= 0 seconds (the state's utime advances by dt), with the configured process noise
  // or another one (e.g. the milder one used while IMU data are missing).
  void predict(double dt) { predict(dt, params_.process); }
  virtual void predict(double dt, const ProcessNoise& q) = 0;
  // Measurement update; rejected (not applied) when the squared Mahalanobis distance exceeds `gate`
  // (pass infinity to disable the gate).
  virtual UpdateResult update(const Measurement& m, double gate) = 0;

  // Stochastic cloning: appends the current body pose as a clone (time = state time) and returns its index.
  int addClone();
  void removeClone(int index);
  // Forgets what is known about error elements [offset, offset + size): their correlations are removed
  // and their variance set, e.g. for the rates after a gap in the IMU data.
  void resetErrorBlock(int offset, int size, double variance);
  virtual std::unique_ptr<KalmanFilter> copy() const = 0;
  // A copy without the pose clones: what a look-ahead to the next image needs. No IMU or tilt measurement involves
  // a clone, so its navigation state and their covariance evolve exactly as the full filter's would, at the cost of
  // the core states (the full covariance with a backlog of clones is ten times larger).
  // Clone `keep` (an index, or -1 for none) stays: the start frame's anchor.
  std::unique_ptr<KalmanFilter> copyWithoutClones(int keep = -1) const;
  // Replaces parts of the state directly (e.g. zeroing stale rates after a gap), keeping P.
  NavState& mutableNav() { return x_.nav; }

 protected:
  explicit KalmanFilter(const FilterParams& params) : params_(params) {}
  void symmetrize();
  // The random walks of the states besides the core (the tracker's scale error) over dt.
  void addRandomWalks(double dt, const ProcessNoise& q);

  FilterParams params_;
  FullState x_;
  Eigen::MatrixXd P_;
};

class ExtendedKalmanFilter : public KalmanFilter {
 public:
  explicit ExtendedKalmanFilter(const FilterParams& params) : KalmanFilter(params) {}
  FilterType type() const override { return FilterType::Ekf; }
  std::unique_ptr<KalmanFilter> copy() const override { return std::make_unique<ExtendedKalmanFilter>(*this); }
  using KalmanFilter::predict;
  void predict(double dt, const ProcessNoise& q) override;
  UpdateResult update(const Measurement& m, double gate) override;
};

class UnscentedKalmanFilter : public KalmanFilter {
 public:
  explicit UnscentedKalmanFilter(const FilterParams& params) : KalmanFilter(params) {}
  FilterType type() const override { return FilterType::Ukf; }
  std::unique_ptr<KalmanFilter> copy() const override { return std::make_unique<UnscentedKalmanFilter>(*this); }
  using KalmanFilter::predict;
  void predict(double dt, const ProcessNoise& q) override;
  UpdateResult update(const Measurement& m, double gate) override;

 private:
  struct Weights {
    double lambda, mean0, cov0, other, spread;
  };
  Weights weights(int n) const;
  // Lower Cholesky factor of P_; adds a small jitter if P_ lost definiteness numerically.
  Eigen::MatrixXd choleskyLower();
  // The first 21 columns of that factor (all rows), from the navigation block only: L11 = chol(P11),
  // L21 = P21 L11^-T. Cheaper, and all that core-only functions need.
  Eigen::MatrixXd choleskyCoreColumns();
  FullState scratch_;
};

std::unique_ptr<KalmanFilter> makeKalmanFilter(const FilterParams& params);

}  // namespace ips::filter
