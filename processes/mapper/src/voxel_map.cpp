#include "ips/mapper/voxel_map.hpp"

#include <open3d/geometry/PointCloud.h>
#include <open3d/io/PointCloudIO.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numeric>
#include <stdexcept>

namespace ips::mapper {

struct VoxelMap::Impl {
  open3d::geometry::PointCloud cloud;  // one point per voxel, grey in the colours (r = g = b)
};

namespace {

open3d::geometry::PointCloud toCloud(const std::vector<Eigen::Vector3d>& points,
                                     const std::vector<uint8_t>& intensity) {
  open3d::geometry::PointCloud c;
  c.points_ = points;
  c.colors_.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const double g = i < intensity.size() ? intensity[i] / 255.0 : 0.0;
    c.colors_.emplace_back(g, g, g);
  }
  return c;
}

// Open3D's VoxelDownSample puts its grid at the corner of each cloud it is given, so a map fused again and
// again would have its voxels shift with its extent: the grid is anchored here instead, one fixed lattice
// (a multiple of the voxel size from the world origin) out to this distance in every direction.
constexpr double kMapHalfExtentM = 10000.0;

std::shared_ptr<open3d::geometry::PointCloud> downsampleOnFixedGrid(const open3d::geometry::PointCloud& cloud,
                                                                    double voxel) {
  const double half = std::ceil(kMapHalfExtentM / voxel) * voxel;
  return std::get<0>(
      cloud.VoxelDownSampleAndTrace(voxel, Eigen::Vector3d::Constant(-half), Eigen::Vector3d::Constant(half)));
}

bool insideGrid(const Eigen::Vector3d& p) { return p.cwiseAbs().maxCoeff() < kMapHalfExtentM; }

}  // namespace

VoxelMap::VoxelMap(double voxel_size_m, int max_voxels)
    : impl_(std::make_unique<Impl>()), voxel_size_m_(voxel_size_m), max_voxels_(max_voxels) {}

VoxelMap::~VoxelMap() = default;

int64_t VoxelMap::insert(const std::vector<Eigen::Vector3d>& points, const std::vector<uint8_t>& intensity,
                         const Eigen::Vector3d& head_position) {
  if (points.empty()) return 0;
  // The stored centroid of a voxel counts as one point beside the new ones, so a voxel follows newer
  // observations (a fading average) rather than freezing on its first.
  open3d::geometry::PointCloud& map = impl_->cloud;
  open3d::geometry::PointCloud incoming = toCloud(points, intensity);
  std::vector<size_t> inside;
  for (size_t i = 0; i < points.size(); ++i)
    if (insideGrid(points[i])) inside.push_back(i);
  const int64_t outside = static_cast<int64_t>(points.size() - inside.size());
  if (outside > 0) incoming = *incoming.SelectByIndex(inside);
  map += incoming;
  map = *downsampleOnFixedGrid(map, voxel_size_m_);
  if (static_cast<int64_t>(map.points_.size()) <= max_voxels_) return outside;
  std::vector<size_t> order(map.points_.size());
  std::iota(order.begin(), order.end(), 0);
  std::nth_element(order.begin(), order.begin() + max_voxels_, order.end(), [&](size_t a, size_t b) {
    return (map.points_[a] - head_position).squaredNorm() < (map.points_[b] - head_position).squaredNorm();
  });
  order.resize(max_voxels_);
  std::sort(order.begin(), order.end());
  const int64_t dropped = static_cast<int64_t>(map.points_.size()) - max_voxels_;
  map = *map.SelectByIndex(order);
  return outside + dropped;
}

void VoxelMap::downsample(double voxel_size_m, std::vector<Eigen::Vector3d>* points, std::vector<uint8_t>* intensity) {
  if (points->empty()) return;
  std::vector<size_t> inside;
  for (size_t i = 0; i < points->size(); ++i)
    if (insideGrid((*points)[i])) inside.push_back(i);
  const auto down = downsampleOnFixedGrid(*toCloud(*points, *intensity).SelectByIndex(inside), voxel_size_m);
  *points = down->points_;
  intensity->resize(down->points_.size());
  for (size_t i = 0; i < down->colors_.size(); ++i)
    (*intensity)[i] = static_cast<uint8_t>(std::lround(std::clamp(down->colors_[i].x(), 0.0, 1.0) * 255));
}

size_t VoxelMap::size() const { return impl_->cloud.points_.size(); }

std::vector<Eigen::Vector3d> VoxelMap::points() const { return impl_->cloud.points_; }

std::vector<uint8_t> VoxelMap::intensity() const {
  std::vector<uint8_t> out;
  for (const auto& c : impl_->cloud.colors_) out.push_back(static_cast<uint8_t>(std::lround(c.x() * 255)));
  return out;
}

void VoxelMap::save(const std::string& path) const {
  open3d::io::WritePointCloudOption option;
  option.write_ascii = open3d::io::WritePointCloudOption::IsAscii::Binary;
  if (!open3d::io::WritePointCloud(path, impl_->cloud, option))
    throw std::runtime_error("cannot write the map to " + path + " (folder missing, or not .ply/.pcd)");
}

std::vector<Eigen::Vector3d> VoxelMap::load(const std::string& path, std::vector<uint8_t>* intensity) {
  if (!std::filesystem::exists(path)) throw std::runtime_error(path + ": no such map file");
  open3d::geometry::PointCloud c;
  if (!open3d::io::ReadPointCloud(path, c)) throw std::runtime_error(path + ": not a PLY/PCD point cloud");
  if (intensity) {
    intensity->assign(c.points_.size(), 0);
    for (size_t i = 0; i < c.colors_.size() && i < c.points_.size(); ++i)
      (*intensity)[i] = static_cast<uint8_t>(std::lround(std::clamp(c.colors_[i].x(), 0.0, 1.0) * 255));
  }
  return c.points_;
}

}  // namespace ips::mapper
