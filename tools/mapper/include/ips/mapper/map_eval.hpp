#pragma once
// A map against the simulator's world: each point's distance to the nearest true surface.
#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "ips/sim/world.hpp"

namespace ips::mapper {

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

}  // namespace ips::mapper
