#include "ips/mapper/map_eval.hpp"

#include <algorithm>

namespace ips::mapper {

SurfaceErrors surfaceErrors(const std::vector<Eigen::Vector3d>& points, const ips::sim::World& world,
                            const Eigen::Isometry3d& T_world_map, double within_m) {
  SurfaceErrors out;
  out.points = points.size();
  if (points.empty()) return out;
  std::vector<double> d;
  d.reserve(points.size());
  size_t within = 0;
  for (const auto& p : points) {
    d.push_back(world.distanceToSurface(T_world_map * p));
    within += d.back() < within_m;
  }
  auto quantile = [&](double q) {
    const size_t k = std::min(d.size() - 1, static_cast<size_t>(q * (d.size() - 1) + 0.5));
    std::nth_element(d.begin(), d.begin() + k, d.end());
    return d[k];
  };
  out.median_m = quantile(0.5);
  out.p90_m = quantile(0.9);
  out.within_pct = 100.0 * within / d.size();
  return out;
}

}  // namespace ips::mapper
