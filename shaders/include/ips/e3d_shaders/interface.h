// The interface between E3D's compute shaders and the host, included by both: by the shaders (GLSL, through
// GL_GOOGLE_include_directive) and by C++ (ips/e3d_shaders/<stage>.h). Each stage header declares its push
// constants once; C++ checks their size with static_assert, so the two sides cannot disagree.
#ifndef IPS_E3D_SHADERS_INTERFACE_H
#define IPS_E3D_SHADERS_INTERFACE_H

// Specialisation-constant ids (layout(constant_id = ...) in the shaders, VkSpecializationMapEntry on the host).
#define E3D_SPEC_SUBGROUP_SIZE 0       // = workgroup size of the line, row and cost shaders
#define E3D_SPEC_LANE_DISPARITIES 1    // K: disparities per subgroup lane
#define E3D_SPEC_NUM_DISPARITIES 2     // D: num_disparities
#define E3D_SPEC_NUM_PATHS 3           // 8 or 4
#define E3D_SPEC_LOG2_SUBGROUP_SIZE 4  // log2(subgroup size)
#define E3D_SPEC_MIN_DISPARITY 5       // min_disparity
#define E3D_SPEC_PHASE 6               // row passes: 0 store the sums, 1 add the stored sums and select
#define E3D_SPEC_MIRROR 7              // the second match (right to left): images read swapped and mirrored
#define E3D_SPEC_RIGHT_MAP 8           // the right map by the diagonal search
#define E3D_SPEC_COST_VOLUME 9         // row passes read the costs from the cost volume (not census on the fly)
#define E3D_SPEC_MI_TABLE_STEP 10      // mi_table: which of its four dispatches (0..3)
#define E3D_SPEC_MI_WINDOW 11          // cost_mi: 1 pixelwise, 3 the mean over 3x3 (SgmParams::mi_window)
#define E3D_SPEC_ROW_PIXELS 12         // row passes: pixels per subgroup, each on subgroup size / this many lanes

// Largest number of buffers (or storage-buffer ranges) a path-cost volume, the row passes' sums or a cost volume
// is split into (each at most maxStorageBufferRange).
#define E3D_MAX_CHUNKS 24
// Widest image: the diagonal search of sgm_wta keeps one row of the right map in shared memory.
#define E3D_MAX_WIDTH 4096
// Disparity maps hold disparity * 16; this value marks pixels without a disparity (ips::e3d::kInvalidDisparity).
#define E3D_INVALID (-32768)
// Workgroup size of the one-dimensional image stages (census, median, downsample, rectify, fill, MI histogram).
#define E3D_GROUP_SIZE 64
// Rows per invocation of census5x5 and median3x3 (each slides its window down a column strip).
#define E3D_STRIP 8
// Rows per subgroup of the 3x3 window costs (cost_window3x3.glsl): the subgroup walks WINDOW_ROWS + 2 image rows and
// each row's pair costs serve up to three output rows. 4: 1.5 pair costs per output instead of 3 with one row
// (640x480 mi on lavapipe: the stage 47 -> 33 ms; 8 rows: 30 ms, but a quarter of the subgroups a GPU would get).
#define E3D_WINDOW_ROWS 4
// Workgroup of lr_check.
#define E3D_LR_GROUP_X 16
#define E3D_LR_GROUP_Y 8
// mi_table: four dispatches of 256 invocations (one per row or column of the table) in workgroups of this size,
// so that lavapipe spreads each over its threads; its work buffers' sizes in entries (see mi_table.comp).
#define E3D_MI_TABLE_GROUP 16
#define E3D_MI_TABLE_STEPS 4
#define E3D_MI_WORK64_ENTRIES (65536 + 256)
#define E3D_MI_WORK32_ENTRIES (2 * 65536 + 4 * 256)
// Mutual Information per image region (SgmParams::mi_region_columns, mi_region_rows): one joint histogram of
// E3D_MI_HISTOGRAM_ENTRIES (65536 bins and the count) and one table of 65536 bytes per region, region-major. The
// region of a coordinate c in [0, extent) split into n regions, region i starting at floor(i * extent / n): the one
// rule of the reference (ips::e3d::miRegionOf) and the shaders.
#define E3D_MI_HISTOGRAM_ENTRIES (65536 + 1)
#define E3D_MI_TABLE_BYTES 65536
#define E3D_MAX_MI_REGIONS 64
#define E3D_REGION_OF(c, n, extent) (((n) * ((c) + 1) - 1) / (extent))
#define E3D_REGION_BEGIN(i, n, extent) ((i) * (extent) / (n))  // region i's first coordinate

#ifdef __cplusplus
#include <cstddef>
#include <cstdint>
#define E3D_INTERFACE_BEGIN \
  namespace ips {           \
  namespace e3d {           \
  namespace shader {
#define E3D_INTERFACE_END \
  }                       \
  }                       \
  }
#define E3D_PUSH_CONSTANTS(Name) struct Name
#define E3D_PUSH_INSTANCE(instance)
#define E3D_CHECK_SIZE(Name, bytes) \
  static_assert(sizeof(Name) == (bytes), #Name ": push constants differ from the shader's block")
E3D_INTERFACE_BEGIN
// GLSL's ivec2 (8-byte aligned in a push-constant block: every use starts at a multiple of 8, checked by offsetof).
struct ivec2 {
  int32_t x, y;
};
E3D_INTERFACE_END
#else
#define E3D_INTERFACE_BEGIN
#define E3D_INTERFACE_END
#define E3D_PUSH_CONSTANTS(Name) layout(push_constant) uniform Name
#define E3D_PUSH_INSTANCE(instance) instance
#define E3D_CHECK_SIZE(Name, bytes) const int E3D_SIZE_##Name = (bytes)  // (checked on the host)
#endif

#endif
