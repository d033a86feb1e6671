#pragma once
// RAII wrappers of the Vulkan objects E3D's stages use: buffers (and texel views of them), descriptor pools,
// compute pipelines with their layouts and descriptor set, and the command buffer a match is recorded into.
// Each owns its handles, is movable and not copyable, and releases them in its destructor.
#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "ips/e3d/vulkan_context.hpp"

namespace ips {
namespace e3d {
namespace vk {

// Moves a handle out of `other`, leaving VK_NULL_HANDLE (for the move operations below).
template <typename T>
T take(T& other) {
  return std::exchange(other, T{});
}

// A storage / texel / uniform buffer with its memory; host-visible buffers stay mapped.
class Buffer {
 public:
  Buffer() = default;
  // Allocates `bytes` (at least 4); adds the allocated size to *allocated_bytes when given.
  Buffer(const VulkanContext& ctx, VkDeviceSize bytes, bool host_visible, size_t* allocated_bytes = nullptr);
  ~Buffer() { reset(); }
  Buffer(Buffer&& other) noexcept { *this = std::move(other); }
  Buffer& operator=(Buffer&& other) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return size_; }
  void* mapped() const { return mapped_; }
  explicit operator bool() const { return buffer_ != VK_NULL_HANDLE; }
  void reset();

 private:
  VkDevice dev_ = VK_NULL_HANDLE;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  void* mapped_ = nullptr;
};

// A texel view of a whole buffer in one format.
class BufferView {
 public:
  BufferView() = default;
  BufferView(VkDevice dev, const Buffer& buffer, VkFormat format);
  ~BufferView() { reset(); }
  BufferView(BufferView&& other) noexcept { *this = std::move(other); }
  BufferView& operator=(BufferView&& other) noexcept;
  BufferView(const BufferView&) = delete;
  BufferView& operator=(const BufferView&) = delete;
  VkBufferView handle() const { return view_; }
  void reset();

 private:
  VkDevice dev_ = VK_NULL_HANDLE;
  VkBufferView view_ = VK_NULL_HANDLE;
};

// One descriptor: a storage (or uniform) buffer range, or a storage texel buffer (`view`). A dynamic uniform
// buffer's range starts at the offset given when the pipeline is bound (Pipeline::bind).
struct Descriptor {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceSize offset = 0, range = VK_WHOLE_SIZE;
  VkBufferView view = VK_NULL_HANDLE;
  bool uniform = false;
  bool dynamic = false;
};

// A binding of a descriptor set: one descriptor, or an array of them.
struct Binding {
  uint32_t binding;
  std::vector<Descriptor> items;
  Binding(uint32_t b, const Buffer& buffer) : binding(b), items{{buffer.handle()}} {}
  Binding(uint32_t b, const BufferView& view) : binding(b), items{{VK_NULL_HANDLE, 0, 0, view.handle()}} {}
  Binding(uint32_t b, std::vector<Descriptor> descriptors) : binding(b), items(std::move(descriptors)) {}
  static Binding uniformBuffer(uint32_t b, const Buffer& buffer) {
    return Binding(b, std::vector<Descriptor>{{buffer.handle(), 0, VK_WHOLE_SIZE, VK_NULL_HANDLE, true}});
  }
  // `range` bytes of `buffer` from the offset bound with the pipeline.
  static Binding dynamicUniformBuffer(uint32_t b, const Buffer& buffer, VkDeviceSize range) {
    return Binding(b, std::vector<Descriptor>{{buffer.handle(), 0, range, VK_NULL_HANDLE, true, true}});
  }
  VkDescriptorType type() const;
};

class DescriptorPool {
 public:
  DescriptorPool() = default;
  // Room for `max_sets` sets with up to `storage_buffers` storage buffers, `texel_buffers` texel buffers and
  // `uniform_buffers` uniform buffers in all (and as many dynamic uniform buffers), on ctx's device; the pipelines
  // built from it ask for its subgroups as the device needs (VulkanContext::subgroupRequest).
  DescriptorPool(const VulkanContext& ctx, uint32_t max_sets, uint32_t storage_buffers, uint32_t texel_buffers,
                 uint32_t uniform_buffers);
  ~DescriptorPool();
  DescriptorPool(DescriptorPool&& other) noexcept { *this = std::move(other); }
  DescriptorPool& operator=(DescriptorPool&& other) noexcept;
  DescriptorPool(const DescriptorPool&) = delete;
  DescriptorPool& operator=(const DescriptorPool&) = delete;
  VkDevice device() const { return dev_; }
  VkDescriptorPool handle() const { return pool_; }
  const VulkanContext::SubgroupRequest& subgroupRequest() const { return subgroup_request_; }

 private:
  VkDevice dev_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VulkanContext::SubgroupRequest subgroup_request_;
};

// Specialisation constants: (id, value) pairs, ids from ips/e3d_shaders/interface.h.
using Specialisation = std::vector<std::pair<uint32_t, int32_t>>;

// A compute pipeline of one embedded shader (ips::shaderCode), its layouts and one descriptor set written with
// `bindings`. A shader whose workgroup size is the subgroup size (the specialisation constant
// E3D_SPEC_SUBGROUP_SIZE: the lane shaders) gets its workgroups as full subgroups where the device can be asked.
class Pipeline {
 public:
  Pipeline() = default;
  Pipeline(const DescriptorPool& pool, const std::string& shader, const std::vector<Binding>& bindings,
           uint32_t push_bytes, const Specialisation& specialisation = {});
  ~Pipeline() { reset(); }
  Pipeline(Pipeline&& other) noexcept { *this = std::move(other); }
  Pipeline& operator=(Pipeline&& other) noexcept;
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;
  explicit operator bool() const { return pipeline_ != VK_NULL_HANDLE; }
  void reset();

  // Binds the pipeline and its descriptor set, every dynamic uniform buffer at `dynamic_offset` bytes.
  void bind(VkCommandBuffer cmd, uint32_t dynamic_offset = 0) const;
  // Pushes the stage's push constants (the struct of its ips/e3d_shaders header).
  template <typename T>
  void push(VkCommandBuffer cmd, const T& values) const {
    pushBytes(cmd, &values, sizeof(T));
  }

 private:
  void pushBytes(VkCommandBuffer cmd, const void* data, uint32_t bytes) const;
  VkDevice dev_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  uint32_t push_bytes_ = 0;
  uint32_t dynamic_buffers_ = 0;
};

// The primary command buffer of a matcher, its pool and fence, and the timestamp queries of its stages.
class CommandBuffer {
 public:
  static constexpr uint32_t kMaxTimestamps = 32;
  explicit CommandBuffer(const VulkanContext& ctx);
  ~CommandBuffer();
  CommandBuffer(const CommandBuffer&) = delete;
  CommandBuffer& operator=(const CommandBuffer&) = delete;

  VkCommandBuffer handle() const { return cmd_; }
  // Resets and begins recording (and resets the timestamps).
  void begin();
  // Writes a timestamp after the work recorded so far, naming the work since the previous one (nullptr: the
  // first stamp). Silently ignored without timestamp support or beyond kMaxTimestamps.
  void timestamp(const char* name);
  // Ends recording with a barrier that makes the shader writes visible to the host, submits and waits.
  void submitAndWait();
  // The device time of each named stage since begin(), in ms.
  std::vector<std::pair<std::string, double>> stageTimes() const;

 private:
  const VulkanContext& ctx_;
  VkDevice dev_;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkQueryPool queries_ = VK_NULL_HANDLE;
  uint32_t stamps_ = 0;
  std::vector<std::string> names_;
};

// Makes the compute writes recorded so far visible to the compute work recorded after it.
void computeBarrier(VkCommandBuffer cmd);
// Zeroes a buffer and makes that visible to the compute work recorded after it.
void fillZero(VkCommandBuffer cmd, const Buffer& buffer);
// Workgroups for n items of `local` each.
inline uint32_t groups(int n, int local) { return static_cast<uint32_t>((n + local - 1) / local); }

}  // namespace vk
}  // namespace e3d
}  // namespace ips
