#include "ips/eval/map_errors.hpp"

#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/PointCloud.h>

#include <algorithm>

namespace ips::eval {

namespace {

double quantile(std::vector<double>& d, double q) {
  const size_t k = std::min(d.size() - 1, static_cast<size_t>(q * (d.size() - 1) + 0.5));
  std::nth_element(d.begin(), d.begin() + k, d.end());
  return d[k];
}

}  // namespace

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
  out.median_m = quantile(d, 0.5);
  out.p90_m = quantile(d, 0.9);
  out.within_pct = 100.0 * within / d.size();
  return out;
}

SelfConsistency selfConsistency(const std::vector<Eigen::Vector3d>& early, const std::vector<Eigen::Vector3d>& late,
                                double overlap_m) {
  SelfConsistency out;
  out.early_points = early.size();
  out.late_points = late.size();
  if (early.empty() || late.empty()) return out;
  open3d::geometry::PointCloud cloud;
  cloud.points_ = early;
  const open3d::geometry::KDTreeFlann tree(cloud);
  std::vector<double> d;
  std::vector<int> index(1);
  std::vector<double> dist2(1);
  for (const auto& p : late)
    if (tree.SearchHybrid(p, overlap_m, 1, index, dist2) > 0) d.push_back(std::sqrt(dist2[0]));
  out.overlapping = d.size();
  if (d.empty()) return out;
  out.median_m = quantile(d, 0.5);
  out.p90_m = quantile(d, 0.9);
  return out;
}

}  // namespace ips::eval
