#include "device/vk_objects.hpp"

#include <algorithm>
#include <stdexcept>

#include "ips/e3d_shaders/interface.h"
#include "ips/shaders.hpp"

namespace ips {
namespace e3d {
namespace vk {

Buffer::Buffer(const VulkanContext& ctx, VkDeviceSize bytes, bool host_visible, size_t* allocated_bytes)
    : dev_(ctx.device()), size_(std::max<VkDeviceSize>(bytes, 4)) {
  VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bi.size = size_;
  bi.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_TEXEL_BUFFER_BIT |
             VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  vkCheck(vkCreateBuffer(dev_, &bi, nullptr, &buffer_), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(dev_, buffer_, &req);
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex =
      host_visible ? ctx.findMemoryType(req.memoryTypeBits,
                                        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                        VK_MEMORY_PROPERTY_HOST_CACHED_BIT)
                   : ctx.findMemoryType(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  const VkResult r = vkAllocateMemory(dev_, &ai, nullptr, &memory_);
  if (r != VK_SUCCESS) reset();
  vkCheck(r, "vkAllocateMemory");
  vkCheck(vkBindBufferMemory(dev_, buffer_, memory_, 0), "vkBindBufferMemory");
  if (host_visible) vkCheck(vkMapMemory(dev_, memory_, 0, VK_WHOLE_SIZE, 0, &mapped_), "vkMapMemory");
  if (allocated_bytes) *allocated_bytes += req.size;
}

Buffer& Buffer::operator=(Buffer&& other) noexcept {
  if (this != &other) {
    reset();
    dev_ = other.dev_;
    buffer_ = take(other.buffer_);
    memory_ = take(other.memory_);
    size_ = take(other.size_);
    mapped_ = take(other.mapped_);
  }
  return *this;
}

void Buffer::reset() {
  if (buffer_) vkDestroyBuffer(dev_, buffer_, nullptr);
  if (memory_) vkFreeMemory(dev_, memory_, nullptr);  // unmaps too
  buffer_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  size_ = 0;
  mapped_ = nullptr;
}

BufferView::BufferView(VkDevice dev, const Buffer& buffer, VkFormat format) : dev_(dev) {
  VkBufferViewCreateInfo vi{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
  vi.buffer = buffer.handle();
  vi.format = format;
  vi.range = VK_WHOLE_SIZE;
  vkCheck(vkCreateBufferView(dev_, &vi, nullptr, &view_), "vkCreateBufferView");
}

BufferView& BufferView::operator=(BufferView&& other) noexcept {
  if (this != &other) {
    reset();
    dev_ = other.dev_;
    view_ = take(other.view_);
  }
  return *this;
}

void BufferView::reset() {
  if (view_) vkDestroyBufferView(dev_, view_, nullptr);
  view_ = VK_NULL_HANDLE;
}

VkDescriptorType Binding::type() const {
  if (items.front().view) return VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER;
  if (items.front().uniform)
    return items.front().dynamic ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
}

DescriptorPool::DescriptorPool(const VulkanContext& ctx, uint32_t max_sets, uint32_t storage_buffers,
                               uint32_t texel_buffers, uint32_t uniform_buffers)
    : dev_(ctx.device()), subgroup_request_(ctx.subgroupRequest()) {
  VkDescriptorPoolSize sizes[4] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, storage_buffers},
                                   {VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER, texel_buffers},
                                   {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, uniform_buffers},
                                   {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC, uniform_buffers}};
  VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pi.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  pi.maxSets = max_sets;
  pi.poolSizeCount = 4;
  pi.pPoolSizes = sizes;
  vkCheck(vkCreateDescriptorPool(dev_, &pi, nullptr, &pool_), "vkCreateDescriptorPool");
}

DescriptorPool::~DescriptorPool() {
  if (pool_) vkDestroyDescriptorPool(dev_, pool_, nullptr);
}

DescriptorPool& DescriptorPool::operator=(DescriptorPool&& other) noexcept {
  if (this != &other) {
    if (pool_) vkDestroyDescriptorPool(dev_, pool_, nullptr);
    dev_ = other.dev_;
    pool_ = take(other.pool_);
    subgroup_request_ = other.subgroup_request_;
  }
  return *this;
}

Pipeline::Pipeline(const DescriptorPool& pool, const std::string& shader, const std::vector<Binding>& bindings,
                   uint32_t push_bytes, const Specialisation& specialisation)
    : dev_(pool.device()), pool_(pool.handle()), push_bytes_(push_bytes) {
  std::vector<VkDescriptorSetLayoutBinding> layout_bindings;
  for (const auto& b : bindings) {
    VkDescriptorSetLayoutBinding l{};
    l.binding = b.binding;
    l.descriptorType = b.type();
    l.descriptorCount = static_cast<uint32_t>(b.items.size());
    if (l.descriptorType == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC) dynamic_buffers_ += l.descriptorCount;
    l.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
    layout_bindings.push_back(l);
  }
  VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  li.bindingCount = static_cast<uint32_t>(layout_bindings.size());
  li.pBindings = layout_bindings.data();
  vkCheck(vkCreateDescriptorSetLayout(dev_, &li, nullptr, &set_layout_), "vkCreateDescriptorSetLayout");
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
  VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pli.setLayoutCount = 1;
  pli.pSetLayouts = &set_layout_;
  pli.pushConstantRangeCount = push_bytes > 0 ? 1 : 0;
  pli.pPushConstantRanges = &range;
  vkCheck(vkCreatePipelineLayout(dev_, &pli, nullptr, &layout_), "vkCreatePipelineLayout");

  const ShaderCode& code = shaderCode(shader);
  VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  mi.codeSize = code.word_count * 4;
  mi.pCode = code.words;
  VkShaderModule module;
  vkCheck(vkCreateShaderModule(dev_, &mi, nullptr, &module), "vkCreateShaderModule");
  std::vector<VkSpecializationMapEntry> entries;
  std::vector<int32_t> values;
  for (const auto& [id, value] : specialisation) {
    entries.push_back({id, static_cast<uint32_t>(4 * values.size()), 4});
    values.push_back(value);
  }
  VkSpecializationInfo spec{static_cast<uint32_t>(entries.size()), entries.data(), values.size() * 4, values.data()};
  VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = module;
  ci.stage.pName = "main";
  ci.stage.pSpecializationInfo = entries.empty() ? nullptr : &spec;
  const bool lanes = std::any_of(specialisation.begin(), specialisation.end(),
                                 [](const auto& e) { return e.first == E3D_SPEC_SUBGROUP_SIZE; });
  const VulkanContext::SubgroupRequest& request = pool.subgroupRequest();
  VkPipelineShaderStageRequiredSubgroupSizeCreateInfoEXT required{
      VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_REQUIRED_SUBGROUP_SIZE_CREATE_INFO_EXT};
  required.requiredSubgroupSize = request.required_size;
  if (lanes && request.full_subgroups) {
    ci.stage.flags |= VK_PIPELINE_SHADER_STAGE_CREATE_REQUIRE_FULL_SUBGROUPS_BIT_EXT;
    if (request.required_size > 0) ci.stage.pNext = &required;
  }
  ci.layout = layout_;
  VkResult r = vkCreateComputePipelines(dev_, VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline_);
  vkDestroyShaderModule(dev_, module, nullptr);
  vkCheck(r, ("vkCreateComputePipelines(" + shader + ")").c_str());

  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = pool_;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &set_layout_;
  vkCheck(vkAllocateDescriptorSets(dev_, &ai, &set_), "vkAllocateDescriptorSets");

  std::vector<std::vector<VkDescriptorBufferInfo>> infos(bindings.size());
  std::vector<std::vector<VkBufferView>> texel_views(bindings.size());
  std::vector<VkWriteDescriptorSet> writes;
  for (size_t i = 0; i < bindings.size(); ++i) {
    for (const Descriptor& d : bindings[i].items) {
      if (d.view)
        texel_views[i].push_back(d.view);
      else
        infos[i].push_back({d.buffer, d.offset, d.range});
    }
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set_;
    w.dstBinding = bindings[i].binding;
    w.descriptorCount = static_cast<uint32_t>(bindings[i].items.size());
    w.descriptorType = bindings[i].type();
    if (texel_views[i].empty())
      w.pBufferInfo = infos[i].data();
    else
      w.pTexelBufferView = texel_views[i].data();
    writes.push_back(w);
  }
  vkUpdateDescriptorSets(dev_, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
}

Pipeline& Pipeline::operator=(Pipeline&& other) noexcept {
  if (this != &other) {
    reset();
    dev_ = other.dev_;
    pool_ = other.pool_;
    set_layout_ = take(other.set_layout_);
    layout_ = take(other.layout_);
    pipeline_ = take(other.pipeline_);
    set_ = take(other.set_);
    push_bytes_ = other.push_bytes_;
    dynamic_buffers_ = other.dynamic_buffers_;
  }
  return *this;
}

void Pipeline::reset() {
  if (pipeline_) vkDestroyPipeline(dev_, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(dev_, layout_, nullptr);
  if (set_layout_) vkDestroyDescriptorSetLayout(dev_, set_layout_, nullptr);
  if (set_) vkFreeDescriptorSets(dev_, pool_, 1, &set_);
  pipeline_ = VK_NULL_HANDLE;
  layout_ = VK_NULL_HANDLE;
  set_layout_ = VK_NULL_HANDLE;
  set_ = VK_NULL_HANDLE;
}

void Pipeline::bind(VkCommandBuffer cmd, uint32_t dynamic_offset) const {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
  const std::vector<uint32_t> offsets(dynamic_buffers_, dynamic_offset);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set_, dynamic_buffers_, offsets.data());
}

void Pipeline::pushBytes(VkCommandBuffer cmd, const void* data, uint32_t bytes) const {
  if (bytes != push_bytes_) throw std::logic_error("Pipeline::push: push constants of the wrong size");
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, bytes, data);
}

CommandBuffer::CommandBuffer(const VulkanContext& ctx) : ctx_(ctx), dev_(ctx.device()) {
  VkCommandPoolCreateInfo ci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  ci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  ci.queueFamilyIndex = ctx.queueFamily();
  vkCheck(vkCreateCommandPool(dev_, &ci, nullptr, &pool_), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cai.commandPool = pool_;
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  vkCheck(vkAllocateCommandBuffers(dev_, &cai, &cmd_), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  vkCheck(vkCreateFence(dev_, &fi, nullptr, &fence_), "vkCreateFence");
  if (ctx.timestampsSupported()) {
    VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = kMaxTimestamps;
    vkCheck(vkCreateQueryPool(dev_, &qi, nullptr, &queries_), "vkCreateQueryPool");
  }
}

CommandBuffer::~CommandBuffer() {
  if (queries_) vkDestroyQueryPool(dev_, queries_, nullptr);
  if (fence_) vkDestroyFence(dev_, fence_, nullptr);
  if (pool_) vkDestroyCommandPool(dev_, pool_, nullptr);
}

void CommandBuffer::begin() {
  vkCheck(vkResetCommandBuffer(cmd_, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vkCheck(vkBeginCommandBuffer(cmd_, &bi), "vkBeginCommandBuffer");
  if (queries_) vkCmdResetQueryPool(cmd_, queries_, 0, kMaxTimestamps);
  stamps_ = 0;
  names_.clear();
}

void CommandBuffer::timestamp(const char* name) {
  if (!queries_ || stamps_ >= kMaxTimestamps) return;
  vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, stamps_++);
  if (name) names_.push_back(name);
}

void CommandBuffer::submitAndWait() {
  VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  mb.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &mb, 0, nullptr, 0,
                       nullptr);
  vkCheck(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd_;
  vkCheck(vkResetFences(dev_, 1, &fence_), "vkResetFences");
  vkCheck(vkQueueSubmit(ctx_.queue(), 1, &si, fence_), "vkQueueSubmit");
  vkCheck(vkWaitForFences(dev_, 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

std::vector<std::pair<std::string, double>> CommandBuffer::stageTimes() const {
  std::vector<std::pair<std::string, double>> times;
  if (!queries_ || stamps_ < 2) return times;
  std::vector<uint64_t> ticks(stamps_);
  vkCheck(vkGetQueryPoolResults(dev_, queries_, 0, stamps_, ticks.size() * 8, ticks.data(), 8,
                                VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
          "vkGetQueryPoolResults");
  for (size_t i = 1; i < stamps_; ++i)
    times.emplace_back(names_[i - 1], static_cast<double>(ticks[i] - ticks[i - 1]) * ctx_.timestampPeriodNs() * 1e-6);
  return times;
}

void computeBarrier(VkCommandBuffer cmd) {
  VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &mb, 0,
                       nullptr, 0, nullptr);
}

void fillZero(VkCommandBuffer cmd, const Buffer& buffer) {
  vkCmdFillBuffer(cmd, buffer.handle(), 0, VK_WHOLE_SIZE, 0);
  VkMemoryBarrier fill{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  fill.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  fill.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &fill, 0,
                       nullptr, 0, nullptr);
}

}  // namespace vk
}  // namespace e3d
}  // namespace ips
