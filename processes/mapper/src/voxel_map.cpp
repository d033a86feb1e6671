#include "ips/mapper/voxel_map.hpp"

#include <open3d/geometry/PointCloud.h>
#include <open3d/io/PointCloudIO.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace ips::mapper {

namespace {

// Points further than this from the world origin are not mapped: no head travels that far from its origin.
constexpr double kMapHalfExtentM = 10000.0;

bool insideGrid(const Eigen::Vector3d& p) { return p.cwiseAbs().maxCoeff() < kMapHalfExtentM; }

// Voxel indices are 32-bit: out to kMapHalfExtentM that holds for voxels of 10 um and more.
constexpr double kMinVoxelM = kMapHalfExtentM / (1 << 30);

void checkVoxelSize(double voxel) {
  if (!(voxel >= kMinVoxelM) || !std::isfinite(voxel))
    throw std::invalid_argument("voxel size " + std::to_string(voxel) + " m: must be finite and at least " +
                                std::to_string(kMinVoxelM) + " m");
}

// A voxel of the fixed lattice: voxel i covers [i v, (i + 1) v) on each axis, anchored at the world origin, so
// that a voxel means the same cell of space however the map grows.
struct VoxelKey {
  int32_t x, y, z;
  bool operator==(const VoxelKey& o) const { return x == o.x && y == o.y && z == o.z; }
};

struct VoxelKeyHash {
  size_t operator()(const VoxelKey& k) const {
    // The spatial hash of Teschner et al. (2003): three large primes, so that neighbouring cells spread.
    return (static_cast<size_t>(static_cast<uint32_t>(k.x)) * 73856093u) ^
           (static_cast<size_t>(static_cast<uint32_t>(k.y)) * 19349663u) ^
           (static_cast<size_t>(static_cast<uint32_t>(k.z)) * 83492791u);
  }
};

VoxelKey keyOf(const Eigen::Vector3d& p, double voxel) {
  return {static_cast<int32_t>(std::floor(p.x() / voxel)), static_cast<int32_t>(std::floor(p.y() / voxel)),
          static_cast<int32_t>(std::floor(p.z() / voxel))};
}

uint8_t greyByte(double grey) { return static_cast<uint8_t>(std::lround(std::clamp(grey, 0.0, 255.0))); }

// The points of one image summed per voxel, in the order their voxels first appear.
struct VoxelSums {
  struct Sum {
    VoxelKey key;
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    double grey = 0;
    int n = 0;
  };
  std::vector<Sum> sums;
  int64_t outside = 0;  // points beyond kMapHalfExtentM

  VoxelSums(const std::vector<Eigen::Vector3d>& points, const std::vector<uint8_t>& intensity, double voxel) {
    std::unordered_map<VoxelKey, size_t, VoxelKeyHash> index;
    for (size_t i = 0; i < points.size(); ++i) {
      if (!insideGrid(points[i])) {
        ++outside;
        continue;
      }
      const VoxelKey key = keyOf(points[i], voxel);
      const auto [it, added] = index.try_emplace(key, sums.size());
      if (added) sums.push_back(Sum{key});
      Sum& s = sums[it->second];
      s.point += points[i];
      s.grey += i < intensity.size() ? intensity[i] : 0;
      ++s.n;
    }
  }
};

}  // namespace

// One entry per voxel: a hash table, so that fusing an image costs its own points, not the map's size (the map
// grows to millions of voxels on a long run; re-binning all of them for every image made each map take longer than
// the one before).
struct VoxelMap::Impl {
  struct Voxel {
    Eigen::Vector3d centroid;
    double grey;  // 0..255
  };
  std::unordered_map<VoxelKey, Voxel, VoxelKeyHash> voxels;
};

VoxelMap::VoxelMap(double voxel_size_m, int max_voxels)
    : impl_(std::make_unique<Impl>()), voxel_size_m_(voxel_size_m), max_voxels_(max_voxels) {
  checkVoxelSize(voxel_size_m);
}

VoxelMap::~VoxelMap() = default;

int64_t VoxelMap::insert(const std::vector<Eigen::Vector3d>& points, const std::vector<uint8_t>& intensity,
                         const Eigen::Vector3d& head_position) {
  if (points.empty()) return 0;
  const VoxelSums incoming(points, intensity, voxel_size_m_);
  auto& voxels = impl_->voxels;
  // The stored centroid of a voxel counts as one point beside the new ones, so a voxel follows newer
  // observations (a fading average) rather than freezing on its first.
  for (const auto& s : incoming.sums) {
    const auto [it, added] = voxels.try_emplace(s.key, Impl::Voxel{s.point / s.n, s.grey / s.n});
    if (added) continue;
    it->second.centroid = (it->second.centroid + s.point) / (s.n + 1);
    it->second.grey = (it->second.grey + s.grey) / (s.n + 1);
  }
  if (static_cast<int64_t>(voxels.size()) <= max_voxels_) return incoming.outside;
  std::vector<std::pair<double, VoxelKey>> by_distance;
  by_distance.reserve(voxels.size());
  for (const auto& [key, v] : voxels) by_distance.emplace_back((v.centroid - head_position).squaredNorm(), key);
  std::nth_element(by_distance.begin(), by_distance.begin() + max_voxels_, by_distance.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  const int64_t dropped = static_cast<int64_t>(by_distance.size()) - max_voxels_;
  for (auto it = by_distance.begin() + max_voxels_; it != by_distance.end(); ++it) voxels.erase(it->second);
  return incoming.outside + dropped;
}

void VoxelMap::downsample(double voxel_size_m, std::vector<Eigen::Vector3d>* points, std::vector<uint8_t>* intensity) {
  checkVoxelSize(voxel_size_m);
  if (points->empty()) return;
  const VoxelSums fused(*points, *intensity, voxel_size_m);
  points->clear();
  intensity->clear();
  for (const auto& s : fused.sums) {
    points->push_back(s.point / s.n);
    intensity->push_back(greyByte(s.grey / s.n));
  }
}

size_t VoxelMap::size() const { return impl_->voxels.size(); }

std::vector<Eigen::Vector3d> VoxelMap::points() const {
  std::vector<Eigen::Vector3d> out;
  out.reserve(impl_->voxels.size());
  for (const auto& [key, v] : impl_->voxels) out.push_back(v.centroid);
  return out;
}

std::vector<uint8_t> VoxelMap::intensity() const {
  std::vector<uint8_t> out;
  out.reserve(impl_->voxels.size());
  for (const auto& [key, v] : impl_->voxels) out.push_back(greyByte(v.grey));
  return out;
}

void VoxelMap::save(const std::string& path) const {
  open3d::geometry::PointCloud cloud;
  cloud.points_.reserve(impl_->voxels.size());
  cloud.colors_.reserve(impl_->voxels.size());
  for (const auto& [key, v] : impl_->voxels) {
    cloud.points_.push_back(v.centroid);
    const double g = greyByte(v.grey) / 255.0;
    cloud.colors_.emplace_back(g, g, g);
  }
  open3d::io::WritePointCloudOption option;
  option.write_ascii = open3d::io::WritePointCloudOption::IsAscii::Binary;
  if (!open3d::io::WritePointCloud(path, cloud, option))
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
