#pragma once
// A map against the simulator's world: each point's distance to the nearest true surface.
#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <vector>

#include "ips/sim/world.hpp"

namespace ips::eval {

struct SurfaceErrors {
  size_t points = 0;
  double median_m = 0;    // median distance to the nearest true surface
  double p90_m = 0;       // 90th percentile
  double within_pct = 0;  // share of points closer than `within_m`
};

// Points are in the world's frame after `T_world_map` (identity for a map built with true poses; the start
// alignment of the filter's frame for a map built with the filter's poses).
SurfaceErrors surfaceErrors(const std::vector<Eigen::Vector3d>& points, const ips::sim::World& world,
                            const Eigen::Isometry3d& T_world_map = Eigen::Isometry3d::Identity(),
                            double within_m = 0.05);

// Where the same surfaces are seen twice (the points of the later part of a run within `overlap_m` of a point of
// the earlier part), how far apart the two views put them: a navigation drift shows as a doubled wall.
struct SelfConsistency {
  size_t early_points = 0, late_points = 0;
  size_t overlapping = 0;  // late points with an early point within overlap_m
  double median_m = NAN;   // median distance of those to their nearest early point
  double p90_m = NAN;
};
SelfConsistency selfConsistency(const std::vector<Eigen::Vector3d>& early, const std::vector<Eigen::Vector3d>& late,
                                double overlap_m);

}  // namespace ips::eval
