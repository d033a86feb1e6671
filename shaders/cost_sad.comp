#version 450
// Matching cost SAD: the mean absolute difference over the 3x3 window, C(x,y,d) =
// min((sum_{dy,dx} |L(x+dx,y+dy) - R(x-d+dx,y+dy)| + 4) / 9, 63), every column and row clamped into the image (see
// ips/e3d/matching_cost.hpp), written into the cost volume (cost_volume.glsl); the window walk is
// cost_window3x3.glsl's.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#include "e3d_common.glsl"
layout(local_size_x_id = E3D_SPEC_SUBGROUP_SIZE) in;
layout(constant_id = E3D_SPEC_LANE_DISPARITIES) const int K = 16;
layout(constant_id = E3D_SPEC_MIRROR) const bool MIRROR = false;
#include "cost_volume.glsl"
#define WINDOW_PAIR_COST(l, r) uint(abs(int(l) - int(r)))
#include "cost_window3x3.glsl"

void main() { window3x3Costs(); }
