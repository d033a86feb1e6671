// Push constants of the image stages: census5x5, median3x3, lr_check, fill_invalid, rectify, downsample.
#ifndef IPS_E3D_SHADERS_IMAGE_STAGES_H
#define IPS_E3D_SHADERS_IMAGE_STAGES_H
#include "ips/e3d_shaders/interface.h"
// The push-constant macros expand to GLSL blocks whose instance name follows the brace: keep it there.
// clang-format off
E3D_INTERFACE_BEGIN

#if defined(__cplusplus) || defined(E3D_IMAGE_PARAMS)
// census5x5, median3x3, fill_invalid: the image size.
E3D_PUSH_CONSTANTS(ImageParams) {
  int width, height;
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(ImageParams, 8);
#endif

#if defined(__cplusplus) || defined(E3D_LR_CHECK_PARAMS)
E3D_PUSH_CONSTANTS(LrCheckParams) {
  int width, height;
  int max_diff16;  // lr_max_diff * 16
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(LrCheckParams, 12);
#endif

#if defined(__cplusplus) || defined(E3D_RECTIFY_PARAMS)
E3D_PUSH_CONSTANTS(RectifyParams) {
  int width, height;          // rectified
  int raw_width, raw_height;  // raw
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(RectifyParams, 16);
#endif

#if defined(__cplusplus) || defined(E3D_DOWNSAMPLE_PARAMS)
E3D_PUSH_CONSTANTS(DownsampleParams) {
  int width, height;            // source
  int half_width, half_height;  // result
} E3D_PUSH_INSTANCE(pc);
E3D_CHECK_SIZE(DownsampleParams, 16);
#endif

E3D_INTERFACE_END
// clang-format on
#endif
