#version 450
// The lane shaders' one assumption about the device, checked by test_e3d_stages on every device it runs on: a
// workgroup of the subgroup size is one whole subgroup whose lanes count 0 .. size - 1 (VulkanContext::
// SubgroupRequest asks the device for that). Each invocation writes its lane and its subgroup's size.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#include "e3d_common.glsl"
layout(local_size_x_id = E3D_SPEC_SUBGROUP_SIZE) in;
layout(std430, binding = 0) writeonly buffer Lanes { uint lanes[]; };

void main() {
  lanes[gl_WorkGroupID.x * gl_WorkGroupSize.x + gl_LocalInvocationID.x] =
      gl_SubgroupInvocationID | (gl_SubgroupSize << 16);
}
