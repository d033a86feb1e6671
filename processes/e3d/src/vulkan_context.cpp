#include "ips/e3d/vulkan_context.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "ips/log.hpp"

namespace ips {
namespace e3d {

void vkCheck(VkResult result, const char* what) {
  if (result != VK_SUCCESS) throw std::runtime_error(std::string(what) + " failed: VkResult " + std::to_string(result));
}

namespace {

VkInstance createInstance() {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "ips_e3d";
  app.apiVersion = VK_API_VERSION_1_1;
  VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ci.pApplicationInfo = &app;
  VkInstance instance = VK_NULL_HANDLE;
  vkCheck(vkCreateInstance(&ci, nullptr, &instance), "vkCreateInstance (is a Vulkan driver installed?)");
  return instance;
}

std::vector<VkPhysicalDevice> physicalDevices(VkInstance instance) {
  uint32_t n = 0;
  vkCheck(vkEnumeratePhysicalDevices(instance, &n, nullptr), "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> devices(n);
  vkCheck(vkEnumeratePhysicalDevices(instance, &n, devices.data()), "vkEnumeratePhysicalDevices");
  return devices;
}

const char* typeName(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return "cpu";
    default:
      return "other";
  }
}

int typeRank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 1;
    default:
      return 0;
  }
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// Why a device cannot run E3D, or "" when it can.
std::string unusable(VkPhysicalDevice pd, uint32_t* queue_family) {
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(pd, &props);
  if (props.apiVersion < VK_API_VERSION_1_1) return "needs Vulkan 1.1";
  VkPhysicalDeviceSubgroupProperties sg{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  p2.pNext = &sg;
  vkGetPhysicalDeviceProperties2(pd, &p2);
  const VkSubgroupFeatureFlags need = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT |
                                      VK_SUBGROUP_FEATURE_SHUFFLE_RELATIVE_BIT | VK_SUBGROUP_FEATURE_BALLOT_BIT;
  if (!(sg.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) || (sg.supportedOperations & need) != need)
    return "needs subgroup basic/arithmetic/shuffle-relative operations in compute";
  if (sg.subgroupSize < 1 || sg.subgroupSize > 64) return "unsupported subgroup size";
  uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, nullptr);
  std::vector<VkQueueFamilyProperties> families(n);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, families.data());
  for (uint32_t i = 0; i < n; ++i)
    if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
      *queue_family = i;
      return "";
    }
  return "no compute queue";
}

bool hasDeviceExtension(VkPhysicalDevice pd, const char* name) {
  uint32_t n = 0;
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, nullptr);
  std::vector<VkExtensionProperties> extensions(n);
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, extensions.data());
  for (const auto& e : extensions)
    if (std::string(e.extensionName) == name) return true;
  return false;
}

}  // namespace

std::vector<VulkanDeviceInfo> VulkanContext::listDevices() {
  VkInstance instance = createInstance();
  std::vector<VulkanDeviceInfo> out;
  auto devices = physicalDevices(instance);
  for (uint32_t i = 0; i < devices.size(); ++i) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(devices[i], &props);
    out.push_back({i, props.deviceName, typeName(props.deviceType)});
  }
  vkDestroyInstance(instance, nullptr);
  return out;
}

VulkanContext::VulkanContext(const std::string& choice_arg) {
  std::string choice = choice_arg;
  if (choice.empty()) {
    const char* env = std::getenv("IPS_VK_DEVICE");
    if (env) choice = env;
  }
  instance_ = createInstance();
  try {
    auto devices = physicalDevices(instance_);
    if (devices.empty()) throw std::runtime_error("VulkanContext: no Vulkan device");
    int chosen = -1;
    if (!choice.empty()) {
      const bool numeric = std::all_of(choice.begin(), choice.end(), [](unsigned char c) { return std::isdigit(c); });
      for (uint32_t i = 0; i < devices.size() && chosen < 0; ++i) {
        VkPhysicalDeviceProperties props;
        vkGetPhysicalDeviceProperties(devices[i], &props);
        if (numeric ? std::stoul(choice) == i : lower(props.deviceName).find(lower(choice)) != std::string::npos)
          chosen = static_cast<int>(i);
      }
      if (chosen < 0) throw std::runtime_error("VulkanContext: no Vulkan device matches '" + choice + "'");
      uint32_t family = 0;
      std::string why = unusable(devices[chosen], &family);
      if (!why.empty()) throw std::runtime_error("VulkanContext: device '" + choice + "' cannot run E3D: " + why);
      queue_family_ = family;
    } else {
      int best_rank = -1;
      for (uint32_t i = 0; i < devices.size(); ++i) {
        uint32_t family = 0;
        if (!unusable(devices[i], &family).empty()) continue;
        VkPhysicalDeviceProperties props;
        vkGetPhysicalDeviceProperties(devices[i], &props);
        if (typeRank(props.deviceType) > best_rank) {
          best_rank = typeRank(props.deviceType);
          chosen = static_cast<int>(i);
          queue_family_ = family;
        }
      }
      if (chosen < 0) throw std::runtime_error("VulkanContext: no Vulkan device can run E3D");
    }
    physical_ = devices[chosen];

    VkPhysicalDeviceSubgroupProperties sg{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    p2.pNext = &sg;
    vkGetPhysicalDeviceProperties2(physical_, &p2);
    const auto& props = p2.properties;
    info_ = {static_cast<uint32_t>(chosen), props.deviceName, typeName(props.deviceType)};
    subgroup_size_ = sg.subgroupSize;
    max_storage_buffer_range_ = props.limits.maxStorageBufferRange;
    max_storage_buffers_per_stage_ = props.limits.maxPerStageDescriptorStorageBuffers;
    timestamp_period_ns_ = props.limits.timestampPeriod;
    vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);
    uint32_t nf = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &nf, nullptr);
    std::vector<VkQueueFamilyProperties> families(nf);
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &nf, families.data());
    timestamps_ = families[queue_family_].timestampValidBits > 0;

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    qci.queueFamilyIndex = queue_family_;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    VkPhysicalDeviceFeatures features{};
    features.shaderStorageBufferArrayDynamicIndexing = VK_TRUE;
    VkPhysicalDeviceFeatures supported;
    vkGetPhysicalDeviceFeatures(physical_, &supported);
    if (!supported.shaderStorageBufferArrayDynamicIndexing)
      throw std::runtime_error("VulkanContext: device lacks shaderStorageBufferArrayDynamicIndexing");
    // Optional: the row-pass layout of the aggregation (64-bit stores, 8- and 64-bit texel formats).
    row_layout_ = supported.shaderInt64 && supported.shaderStorageImageExtendedFormats;
    features.shaderInt64 = supported.shaderInt64;
    features.shaderStorageImageExtendedFormats = supported.shaderStorageImageExtendedFormats;
    VkPhysicalDeviceMaintenance3Properties m3{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES};
    VkPhysicalDeviceProperties2 p3{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    p3.pNext = &m3;
    vkGetPhysicalDeviceProperties2(physical_, &p3);
    max_allocation_bytes_ = m3.maxMemoryAllocationSize;
    max_texel_buffer_elements_ = p3.properties.limits.maxTexelBufferElements;
    // The lane shaders' workgroups as one full subgroup of subgroup_size_ (SubgroupRequest).
    VkPhysicalDeviceSubgroupSizeControlFeaturesEXT size_control{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_SIZE_CONTROL_FEATURES_EXT};
    std::vector<const char*> extensions;
    if (hasDeviceExtension(physical_, VK_EXT_SUBGROUP_SIZE_CONTROL_EXTENSION_NAME)) {
      VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
      f2.pNext = &size_control;
      vkGetPhysicalDeviceFeatures2(physical_, &f2);
      VkPhysicalDeviceSubgroupSizeControlPropertiesEXT sizes{
          VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_SIZE_CONTROL_PROPERTIES_EXT};
      VkPhysicalDeviceProperties2 p4{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
      p4.pNext = &sizes;
      vkGetPhysicalDeviceProperties2(physical_, &p4);
      // Full subgroups alone need the workgroup to be a multiple of the largest size; else the size is pinned.
      const bool pin = sizes.maxSubgroupSize != subgroup_size_;
      const bool can_pin = size_control.subgroupSizeControl &&
                           (sizes.requiredSubgroupSizeStages & VK_SHADER_STAGE_COMPUTE_BIT) &&
                           subgroup_size_ >= sizes.minSubgroupSize && subgroup_size_ <= sizes.maxSubgroupSize;
      if (size_control.computeFullSubgroups && (!pin || can_pin)) {
        subgroup_request_ = {true, pin ? subgroup_size_ : 0u};
        size_control.subgroupSizeControl = pin ? VK_TRUE : VK_FALSE;
        extensions.push_back(VK_EXT_SUBGROUP_SIZE_CONTROL_EXTENSION_NAME);
      }
    }
    if (!subgroup_request_.full_subgroups)
      IPS_WARN("e3d: Vulkan device '" << props.deviceName
                                      << "' cannot be asked for full subgroups (VK_EXT_subgroup_size_control): "
                                         "the lane shaders assume each workgroup is one whole subgroup");
    VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    dci.pEnabledFeatures = &features;
    dci.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
    dci.ppEnabledExtensionNames = extensions.data();
    if (subgroup_request_.full_subgroups) dci.pNext = &size_control;
    vkCheck(vkCreateDevice(physical_, &dci, nullptr, &device_), "vkCreateDevice");
    vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
    IPS_INFO("e3d: Vulkan device " << info_.index << " '" << info_.name << "' (" << info_.type << "), subgroup size "
                                   << subgroup_size_
                                   << (subgroup_request_.full_subgroups
                                           ? (subgroup_request_.required_size > 0 ? ", full and pinned" : ", full")
                                           : ""));
  } catch (...) {
    if (device_) vkDestroyDevice(device_, nullptr);
    vkDestroyInstance(instance_, nullptr);
    throw;
  }
}

VulkanContext::~VulkanContext() {
  if (device_) vkDestroyDevice(device_, nullptr);
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

uint32_t VulkanContext::findMemoryType(uint32_t type_bits, VkMemoryPropertyFlags required,
                                       VkMemoryPropertyFlags preferred) const {
  int fallback = -1;
  for (uint32_t i = 0; i < memory_.memoryTypeCount; ++i) {
    if (!(type_bits & (1u << i))) continue;
    const VkMemoryPropertyFlags f = memory_.memoryTypes[i].propertyFlags;
    if ((f & required) != required) continue;
    if ((f & preferred) == preferred) return i;
    if (fallback < 0) fallback = static_cast<int>(i);
  }
  if (fallback < 0) throw std::runtime_error("VulkanContext: no suitable memory type");
  return static_cast<uint32_t>(fallback);
}

}  // namespace e3d
}  // namespace ips
