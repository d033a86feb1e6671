#include "ips/mapper/params.hpp"

namespace ips::mapper {

MapperParams loadMapperParams(const Config& cfg) {
  MapperParams p;
  p.disparity_sigma_px = cfg.getDouble("mapper/disparity_sigma_px", p.disparity_sigma_px);
  p.max_depth_sigma_m = cfg.getDouble("mapper/max_depth_sigma_m", p.max_depth_sigma_m);
  p.min_range_m = cfg.getDouble("mapper/min_range_m", p.min_range_m);
  p.pixel_step = cfg.getInt("mapper/pixel_step", p.pixel_step);
  p.voxel_size_m = cfg.getDouble("mapper/voxel_size_m", p.voxel_size_m);
  p.max_voxels = cfg.getInt("mapper/max_voxels", p.max_voxels);
  p.max_pose_gap_s = cfg.getDouble("mapper/max_pose_gap_s", p.max_pose_gap_s);
  p.max_pending_maps = cfg.getInt("mapper/max_pending_maps", p.max_pending_maps);
  p.max_pending_images = cfg.getInt("mapper/max_pending_images", p.max_pending_images);
  p.texture_window_px = cfg.getInt("mapper/texture_window_px", p.texture_window_px);
  p.alignment_min_grey_spread = cfg.getDouble("mapper/alignment_min_grey_spread", p.alignment_min_grey_spread);
  if (!(p.disparity_sigma_px > 0 && p.max_depth_sigma_m > 0 && p.min_range_m >= 0 && p.pixel_step >= 1 &&
        p.voxel_size_m > 0 && p.max_voxels >= 1 && p.max_pose_gap_s > 0 && p.max_pending_maps >= 1 &&
        p.max_pending_images >= 1 && p.texture_window_px >= 3 && p.texture_window_px % 2 == 1 &&
        p.alignment_min_grey_spread >= 0))
    throw ConfigError(cfg.path() +
                      ": mapper/ keys out of range (sigmas, sizes and gaps > 0, min_range_m >= 0, counts >= 1, "
                      "texture_window_px odd and >= 3, alignment_min_grey_spread >= 0)");
  return p;
}

}  // namespace ips::mapper
