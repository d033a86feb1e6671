#pragma once
// The fused map: points averaged per voxel of a fixed lattice (a hash table of voxels: fusing an image costs its
// own points, whatever the map's size), bounded in size, written as PLY or PCD (Open3D's writers). Open3D stays
// inside voxel_map.cpp.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace ips::mapper {

class VoxelMap {
 public:
  // Throws std::invalid_argument for a voxel size below 10 um (the voxel indices are 32-bit) or not finite.
  VoxelMap(double voxel_size_m, int max_voxels);
  ~VoxelMap();

  // Adds points (with their grey values) seen from `head_position`; voxels beyond max_voxels furthest from it
  // are dropped, and points further than 10 km from the world origin are not mapped. Returns how many of
  // either.
  int64_t insert(const std::vector<Eigen::Vector3d>& points, const std::vector<uint8_t>& intensity,
                 const Eigen::Vector3d& head_position);
  // The same points fused per voxel, without adding them (the per-image cloud published on the bus).
  static void downsample(double voxel_size_m, std::vector<Eigen::Vector3d>* points, std::vector<uint8_t>* intensity);

  size_t size() const;
  std::vector<Eigen::Vector3d> points() const;
  std::vector<uint8_t> intensity() const;
  // Writes the map; the format follows the extension (.ply, .pcd). Throws std::runtime_error on failure.
  void save(const std::string& path) const;
  // Reads a map written by save() (or any PLY/PCD point cloud), with its grey values when asked (0 for a cloud
  // without colours). Throws std::runtime_error naming the file.
  static std::vector<Eigen::Vector3d> load(const std::string& path, std::vector<uint8_t>* intensity = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double voxel_size_m_;
  int max_voxels_;
};

}  // namespace ips::mapper
