#pragma once
// Navigation aided by the dense cloud (paper section 6): each of E3D's maps, as points in camera 0 at its time, is
// aligned with the previous map by point-to-plane ICP (Gauss-Newton on Open3D's thinning, normals and KD-tree),
// starting from the relative pose the navigation filter gives between the two times. The result is a relative-pose
// measurement of camera 0 between the two map times, in the convention of a tracker delta (X_prev = R X_now + t), with
// a covariance from the alignment's own geometry: a straight corridor fixes the motion across it and the rotation, but
// not the motion along it; there the result keeps the prior and the covariance says so (its information is the sum over
// the point pairs of the normals' constraints). No middleware: the mapper process feeds it and publishes the result on
// CLOUD_DELTA for the filter.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ips/config.hpp"

namespace ips::mapper {

struct CloudOdometryParams {
  // Points are thinned to one per voxel of this edge [m] before the alignment: twice the map's 5 cm voxels keeps
  // the shape of walls and furniture, and the work falls with the cube of it.
  double voxel_size_m = 0.10;
  // Normals of the previous map from its points within this radius [m], at most this many: a few voxels span the
  // local plane of a wall without reaching round its corners.
  double normal_radius_m = 0.30;
  int normal_max_neighbours = 30;
  // Point pairs further apart than this after the prior are not paired [m]. The filter's relative pose between two
  // maps 3 s apart is good to centimetres (the walk's 0.06 % of distance), so 0.25 m is a wide margin that
  // still keeps a point from pairing with a different wall (corridors are 2.4 m wide, furniture 0.5 m apart).
  double max_correspondence_m = 0.25;
  int max_iterations = 30;
  // Scale of the Cauchy weight on a pair's residual, in its sigmas: pairs beyond a few sigmas (a wrong disparity, a
  // point of another surface) lose their weight instead of pulling the result.
  double robust_sigmas = 2.0;
  // An alignment that moved the prior by more than max_correspondence_m or this angle [deg] has slid along a corridor
  // or onto other structure (the filter's relative pose is better than that): no measurement ("diverged").
  double max_correction_deg = 2.0;
  // Below this share of the current map's points with a partner, the maps see too little of the same structure
  // (a turn into a new corridor between them): no measurement.
  double min_overlap = 0.3;
  // Fewer pairs than this: no measurement. Only textured points are aligned (MapperParams::alignment_min_grey_spread),
  // a few hundred 10 cm voxels on plain walls, where furniture, doors and corners carry the shape; 100 pairs still
  // fix the 6 unknowns many times over, and the test of the constrained directions drops what they leave open.
  int min_correspondences = 100;
  // Neighbouring points of one disparity map are not independent (SGM's aggregation and smoothing spread one
  // matching error over many pixels): the covariance from the residuals, which treats every pair as independent,
  // is multiplied by this (roughly the pixels one SGM error spans, 5 x 5). cloud_odometry_eval finds the result
  // conservative on the simulated walk (NEES 1.5 of 6) and about right on plain walls (6.6), with a map every 3 s,
  // and conservative on both with a map every second (1.3, 2.4): see the README.
  double covariance_inflation = 25.0;
  // Sigma of a point-to-plane residual besides the points' depth errors along their rays [m]: the thinning to voxels
  // and the normals' own error; also keeps a perfect fit from claiming infinite information.
  double min_residual_sigma_m = 0.005;
  // The prior's information in the alignment (1 / these squared, [m], [rad]): weak, so that where the maps constrain
  // the motion their result stands, and where they do not (a corridor along its axis) the result keeps the prior
  // with about this sigma, saying the measurement knows nothing of it (well above the filter's own uncertainty).
  double unconstrained_sigma_t = 1.0;
  double unconstrained_sigma_r = 0.3;
  // A direction counts as fixed by the maps when their sigma there is this many times below the unconstrained one
  // (30: 3.3 cm along a corridor, 0.57 deg of turn); in the others the result is the prior's. Lower, the noise of
  // E3D's points (a fifth of a pixel) makes a corridor's axis look fixed when it is not, and the maps slide along it
  // by decimetres (cloud_odometry_eval on the simulated walk: none slides at 30, several at 10).
  double constrained_factor = 30.0;

  static CloudOdometryParams fromConfig(const Config& cfg);
};

// The result of aligning one map with the previous one.
struct CloudDelta {
  bool valid = false;
  std::string reason;      // why not valid: "first_map", "too_few_points", "little_overlap", ...
  int64_t utime = 0;       // of the current map
  int64_t utime_prev = 0;  // of the previous one
  Eigen::Isometry3d T_prev_now = Eigen::Isometry3d::Identity();  // camera 0 now in camera 0 at utime_prev
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  // tx ty tz rx ry rz
  Eigen::Isometry3d prior = Eigen::Isometry3d::Identity();  // what the filter said, the alignment's start
  int points = 0;                                           // of the current map after thinning
  int correspondences = 0;
  double overlap = 0;              // correspondences / points
  double rmse_m = 0;               // point-to-plane residual of the pairs
  int constrained_directions = 0;  // of the 6: the others keep the prior (a corridor's axis)
};

class CloudOdometry {
 public:
  explicit CloudOdometry(const CloudOdometryParams& params);
  ~CloudOdometry();
  CloudOdometry(const CloudOdometry&) = delete;
  CloudOdometry& operator=(const CloudOdometry&) = delete;

  // One map: its points in the world as the mapper placed them and the pose of camera 0 in the world at its time
  // (both from the filter; only the relative pose of two maps is used), and its depth precision
  // sigma_z = depth_sigma_per_m2 * z^2 (sigma_d / (f b) of its camera pair). Maps in time order. The map becomes
  // the reference of the next one whatever the result.
  CloudDelta add(int64_t utime, const std::vector<Eigen::Vector3d>& world_points, const Eigen::Isometry3d& T_world_cam,
                 double depth_sigma_per_m2);

  // The alignment alone: `now` (points in camera 0 now) onto `prev` (points in camera 0 before), from `prior`.
  CloudDelta align(const std::vector<Eigen::Vector3d>& prev, const std::vector<Eigen::Vector3d>& now,
                   const Eigen::Isometry3d& prior, double depth_sigma_per_m2) const;

  const CloudOdometryParams& params() const { return params_; }

 private:
  struct Reference;
  CloudOdometryParams params_;
  std::unique_ptr<Reference> prev_;
};

}  // namespace ips::mapper
