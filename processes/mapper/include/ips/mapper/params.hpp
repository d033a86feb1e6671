#pragma once
// Settings of the mapper (config/mapper.yaml), each with the reason for its default.
#include "ips/config.hpp"

namespace ips::mapper {

struct MapperParams {
  // Precision of one disparity [px]: semi-global matching with parabola subpixel refinement is good to about
  // a quarter pixel on textured surfaces (the E3D README's figures on the evaluation scenes).
  double disparity_sigma_px = 0.25;
  // Depth error grows with the square of the range: sigma_z = z^2 sigma_d / (f b). A point is kept while
  // sigma_z stays below this [m], twice the voxel size, so that one voxel is not smeared over more than its
  // neighbours. The range this gives follows from the head: sqrt(max_depth_sigma_m f b / sigma_d), e.g.
  // 12.3 m for KITTI (rectified f 707 px, b 0.54 m), 5.4 m for the simulated head at half resolution (f 359 px,
  // b 0.2 m); the mapper logs it for its head when the first map arrives.
  double max_depth_sigma_m = 0.10;
  // Closer than this the head's own mounting and the operator show up in the images [m].
  double min_range_m = 0.3;
  // Every n-th pixel of the map in both directions: neighbouring pixels at the ranges kept are closer than
  // one voxel, so the map loses nothing and the work is divided by n^2.
  int pixel_step = 2;
  // Edge of a map voxel [m]: the points of one voxel are fused into their centroid. 5 cm is the accuracy
  // asked of the map and about the depth precision at 4-5 m.
  double voxel_size_m = 0.05;
  // The map's bound: beyond this many voxels the ones furthest from the head are dropped (a building of
  // 100 x 100 m with walls every few metres fits; memory about 40 bytes per voxel).
  int max_voxels = 3000000;
  // Poses of the navigation filter are interpolated between states at most this far apart [s] (the filter
  // publishes at the IMU rate, 5 ms apart; a longer gap is a filter restart).
  double max_pose_gap_s = 0.1;
  // Disparity maps waiting for the pose at their time; beyond this the oldest is dropped (counted).
  int max_pending_maps = 8;
  // Stereo pairs kept for the grey value of the points (the map of a pair arrives a few pairs later).
  int max_pending_images = 32;
  // The alignment of maps (CLOUD_DELTA) takes only points whose pixel has texture of its own: the standard deviation
  // of the rectified left image's grey values in a texture_window_px square (census's 5 x 5) at least
  // alignment_min_grey_spread. Where that window holds nothing but the cameras' noise (1.5 grey levels at 8 bit for
  // the head's cameras), SGM's disparity comes from the neighbours through the smoothness terms: on a plain wall it
  // follows the wall's edges, not the wall, and two such maps aligned pull each other by their errors
  // (cloud_odometry_eval on plain walls: 8.8 cm and 0.85 deg off with all points, worse than the prior's 5.8 cm).
  // The spread of 25 grey values of noise alone scatters by 1.5 / sqrt(2 x 24) = 0.22 around 1.5, so 2.0 lies more
  // than two of those above it: few windows of noise alone pass, and every window whose own relief is about the
  // noise's (painted plaster) does, which census still matches. Twice the noise (3.0) kept out most of the plaster and
  // left the alignment too few points exactly where the tracker fails (processes/mapper/README.md). The map itself
  // keeps every point.
  int texture_window_px = 5;
  double alignment_min_grey_spread = 2.0;
};

MapperParams loadMapperParams(const Config& cfg);

}  // namespace ips::mapper
