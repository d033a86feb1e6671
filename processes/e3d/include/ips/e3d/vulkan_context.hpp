#pragma once
// The Vulkan instance, the chosen physical device and one compute queue, shared by E3D's stages.
#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

namespace ips {
namespace e3d {

struct VulkanDeviceInfo {
  uint32_t index = 0;
  std::string name;
  std::string type;  // "discrete", "integrated", "virtual", "cpu", "other"
};

class VulkanContext {
 public:
  // Picks a device: `choice` (or, when empty, the environment variable IPS_VK_DEVICE) is either a device
  // index or a case-insensitive substring of the device name; otherwise the best type wins:
  // discrete GPU > integrated GPU > virtual GPU > CPU (lavapipe). Logs the choice.
  // Throws std::runtime_error when there is no usable device (needs Vulkan 1.1 and subgroup
  // basic/arithmetic/shuffle-relative operations in compute shaders).
  explicit VulkanContext(const std::string& choice = "");
  ~VulkanContext();
  VulkanContext(const VulkanContext&) = delete;
  VulkanContext& operator=(const VulkanContext&) = delete;

  static std::vector<VulkanDeviceInfo> listDevices();

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physicalDevice() const { return physical_; }
  VkDevice device() const { return device_; }
  VkQueue queue() const { return queue_; }
  uint32_t queueFamily() const { return queue_family_; }
  const VulkanDeviceInfo& info() const { return info_; }
  uint32_t subgroupSize() const { return subgroup_size_; }
  // How a pipeline whose workgroup is one subgroup (local size = subgroupSize(), the lane shaders) must ask for it.
  // Without asking, an implementation may split such a workgroup into partial subgroups (lavapipe with 1024-bit
  // vectors runs subgroups of 32 as two halves whose lanes count 0-15 each; a GPU with variable subgroup sizes may
  // pick another size): full_subgroups asks for full ones (VK_EXT_subgroup_size_control's computeFullSubgroups),
  // required_size, where not 0, also pins their size (to subgroupSize(), where the device's largest differs from it).
  struct SubgroupRequest {
    bool full_subgroups = false;
    uint32_t required_size = 0;
  };
  const SubgroupRequest& subgroupRequest() const { return subgroup_request_; }
  uint64_t maxStorageBufferRange() const { return max_storage_buffer_range_; }
  uint32_t maxStorageBuffersPerStage() const { return max_storage_buffers_per_stage_; }
  double timestampPeriodNs() const { return timestamp_period_ns_; }
  bool timestampsSupported() const { return timestamps_; }
  // Whether the device can run the row-pass aggregation (shaderInt64, shaderStorageImageExtendedFormats).
  bool supportsRowLayout() const { return row_layout_; }
  uint64_t maxAllocationBytes() const { return max_allocation_bytes_; }
  uint64_t maxTexelBufferElements() const { return max_texel_buffer_elements_; }
  // A memory type index with all `required` flags (and `preferred` ones when possible) for `type_bits`.
  uint32_t findMemoryType(uint32_t type_bits, VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred) const;

 private:
  VkInstance instance_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  VulkanDeviceInfo info_;
  uint32_t subgroup_size_ = 0;
  SubgroupRequest subgroup_request_;
  uint64_t max_storage_buffer_range_ = 0;
  uint32_t max_storage_buffers_per_stage_ = 0;
  double timestamp_period_ns_ = 1.0;
  bool timestamps_ = false;
  bool row_layout_ = false;
  uint64_t max_allocation_bytes_ = 0;
  uint64_t max_texel_buffer_elements_ = 0;
  VkPhysicalDeviceMemoryProperties memory_{};
};

// Throws std::runtime_error("<what>: <VkResult>") when result is not VK_SUCCESS.
void vkCheck(VkResult result, const char* what);

}  // namespace e3d
}  // namespace ips
