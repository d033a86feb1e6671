#include "ips/e3d/stereo_matcher.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "ips/shaders.hpp"

namespace ips {
namespace e3d {

namespace {

constexpr int kMaxChunks = 24;   // E3D_MAX_CHUNKS in shaders/e3d_common.glsl
constexpr int kMaxWidth = 4096;  // E3D_MAX_WIDTH in shaders/sgm_wta.comp
constexpr uint32_t kMaxTimestamps = 32;
// lavapipe (gallivm) ends a shader invocation after 65535 loop iterations counted over all its loops; shaders that
// walk far are dispatched in parts that stay below this (with a margin for loops the compiler does not unroll).
constexpr int kMaxLoopIterations = 60000;
constexpr int kStrip = 8;  // rows per invocation of census5x5 and median3x3 (STRIP there)

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;
};

// One descriptor: a storage (or uniform) buffer (a range of `buffer`) or a storage texel buffer (`view`).
struct Descriptor {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceSize offset = 0, range = VK_WHOLE_SIZE;
  VkBufferView view = VK_NULL_HANDLE;
  bool uniform = false;
};

struct Binding {
  uint32_t binding;
  std::vector<Descriptor> items;  // more than one: a descriptor array
  Binding(uint32_t b, std::vector<const Buffer*> buffers) : binding(b) {
    for (const Buffer* buf : buffers) items.push_back({buf->buffer, 0, VK_WHOLE_SIZE, VK_NULL_HANDLE});
  }
  Binding(uint32_t b, std::vector<Descriptor> descriptors) : binding(b), items(std::move(descriptors)) {}
  Binding(uint32_t b, VkBufferView view) : binding(b), items{{VK_NULL_HANDLE, 0, 0, view}} {}
  static Binding uniformBuffer(uint32_t b, const Buffer& buf) {
    return Binding(b, std::vector<Descriptor>{{buf.buffer, 0, VK_WHOLE_SIZE, VK_NULL_HANDLE, true}});
  }
  VkDescriptorType type() const {
    if (items.front().view) return VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER;
    return items.front().uniform ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  }
};

// Specialisation of the matching stages: the phase of the row passes, the mirrored second match, the diagonal
// search for the right map.
struct Variant {
  int phase = 0;
  bool mirror = false;
  bool right_map = true;
  bool cost_volume = false;  // the row passes read the costs from the cost volume (not census on the fly)
};

struct Stage {
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
};

}  // namespace

struct StereoMatcher::Impl {
  VulkanContext& ctx;
  VkDevice dev;
  cv::Size size;
  SgmParams params;
  bool rows = false;   // the aggregation layout: row passes (true) or lines (false), see SgmParams::aggregation
  int lane_disps = 0;  // K: disparities per subgroup lane
  int padded_disps = 0;
  int rows_per_chunk = 0;
  int row_words = 0;
  int num_chunks = 0;
  size_t memory_bytes = 0;

  Buffer image[2], census[2], disp[2], median[2], final_disp, filled_disp;
  std::vector<Buffer> volume;           // lines: path-cost volume split over buffers
  Buffer scratch, sums;                 // rows: two rows of path costs per pass, the sums of both passes
  Buffer costs;                         // rows, costs other than census: the cost volume
  std::vector<Descriptor> cost_chunks;  // where the cost stages write (rows: costs, lines: the volume's cost slice)
  int cost_base_row = 0, cost_rows_per_chunk = 0, cost_row_words = 0;
  // Mutual Information: the histogram (65536 bins + count), the table, work space, the log2 fractions; the
  // coarser levels of the hierarchy (levels[0]: half size, ...), each a matcher of its own that records into this
  // one's command buffer; a level reads the images of the level above it (downsample).
  Buffer mi_histogram, mi_table_buffer, mi_work64, mi_work32, mi_log2;
  Stage mi_start_histogram, mi_guided_histogram, mi_table_stage, downsample_stage;
  std::vector<std::unique_ptr<Impl>> levels;
  cv::Size guide_size;  // the size of the level below, whose checked map mi_guided_histogram reads
  bool is_level = false;  // a coarser level: no command buffer of its own
  std::vector<VkBufferView> views;
  VkBufferView image_words[2] = {};  // the 8-bit images as 32-bit texels (four pixels each)
  Buffer raw[2], maps;
  cv::Size raw_size;
  bool has_rect = false;

  VkDescriptorPool pool = VK_NULL_HANDLE;
  // The matching stages of one match: rows use aggregate (phase 0) and wta (phase 1), lines all three.
  struct MatchStages {
    Stage cost, aggregate, wta;
  };
  MatchStages left_match, right_match;  // right_match: the mirrored second match (right_map "match")
  Stage census_stage, median_stage, lr_stage, fill_stage, rectify_stage;
  VkCommandPool cmd_pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkQueryPool queries = VK_NULL_HANDLE;

  Impl(VulkanContext& c, cv::Size s, const SgmParams& p) : ctx(c), dev(c.device()), size(s), params(p) {}

  Buffer createBuffer(VkDeviceSize bytes, bool host_visible) {
    Buffer b;
    b.size = std::max<VkDeviceSize>(bytes, 4);
    VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    bi.size = b.size;
    bi.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_TEXEL_BUFFER_BIT |
               VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    vkCheck(vkCreateBuffer(dev, &bi, nullptr, &b.buffer), "vkCreateBuffer");
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(dev, b.buffer, &req);
    VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    ai.allocationSize = req.size;
    ai.memoryTypeIndex =
        host_visible ? ctx.findMemoryType(req.memoryTypeBits,
                                          VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                          VK_MEMORY_PROPERTY_HOST_CACHED_BIT)
                     : ctx.findMemoryType(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    vkCheck(vkAllocateMemory(dev, &ai, nullptr, &b.memory), "vkAllocateMemory");
    vkCheck(vkBindBufferMemory(dev, b.buffer, b.memory, 0), "vkBindBufferMemory");
    if (host_visible) vkCheck(vkMapMemory(dev, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
    memory_bytes += req.size;
    return b;
  }

  VkBufferView createView(const Buffer& b, VkFormat format) {
    VkBufferViewCreateInfo vi{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
    vi.buffer = b.buffer;
    vi.format = format;
    vi.range = VK_WHOLE_SIZE;
    VkBufferView view;
    vkCheck(vkCreateBufferView(dev, &vi, nullptr, &view), "vkCreateBufferView");
    views.push_back(view);
    return view;
  }

  void destroyBuffer(Buffer& b) {
    if (b.buffer) vkDestroyBuffer(dev, b.buffer, nullptr);
    if (b.memory) vkFreeMemory(dev, b.memory, nullptr);
    b = Buffer{};
  }

  Stage createStage(const std::string& shader, const std::vector<Binding>& bindings, uint32_t push_bytes,
                    bool specialise, Variant variant = {}) {
    Stage st;
    std::vector<VkDescriptorSetLayoutBinding> lb;
    for (const auto& b : bindings) {
      VkDescriptorSetLayoutBinding l{};
      l.binding = b.binding;
      l.descriptorType = b.type();
      l.descriptorCount = static_cast<uint32_t>(b.items.size());
      l.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
      lb.push_back(l);
    }
    VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    li.bindingCount = static_cast<uint32_t>(lb.size());
    li.pBindings = lb.data();
    vkCheck(vkCreateDescriptorSetLayout(dev, &li, nullptr, &st.set_layout), "vkCreateDescriptorSetLayout");
    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
    VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    pli.setLayoutCount = 1;
    pli.pSetLayouts = &st.set_layout;
    pli.pushConstantRangeCount = 1;
    pli.pPushConstantRanges = &range;
    vkCheck(vkCreatePipelineLayout(dev, &pli, nullptr, &st.layout), "vkCreatePipelineLayout");

    const ShaderCode& code = shaderCode(shader);
    VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    mi.codeSize = code.word_count * 4;
    mi.pCode = code.words;
    VkShaderModule module;
    vkCheck(vkCreateShaderModule(dev, &mi, nullptr, &module), "vkCreateShaderModule");
    // Constant ids: 0 subgroup size (= workgroup size), 1 K, 2 num_disparities, 3 paths, 4 log2(subgroup size),
    // 6 min_disparity, 7 phase of the row passes, 8 mirror, 9 right map, 10 cost volume (5 is unused).
    int log2_sg = 0;
    while ((1u << (log2_sg + 1)) <= ctx.subgroupSize()) ++log2_sg;
    const int32_t spec_values[11] = {static_cast<int32_t>(ctx.subgroupSize()),
                                     lane_disps,
                                     params.num_disparities,
                                     params.paths,
                                     log2_sg,
                                     0,
                                     params.min_disparity,
                                     variant.phase,
                                     variant.mirror ? 1 : 0,
                                     variant.right_map ? 1 : 0,
                                     variant.cost_volume ? 1 : 0};
    VkSpecializationMapEntry entries[11];
    for (uint32_t i = 0; i < 11; ++i) entries[i] = {i, 4 * i, 4};
    VkSpecializationInfo spec{11, entries, sizeof(spec_values), spec_values};
    VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = module;
    ci.stage.pName = "main";
    ci.stage.pSpecializationInfo = specialise ? &spec : nullptr;
    ci.layout = st.layout;
    VkResult r = vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &ci, nullptr, &st.pipeline);
    vkDestroyShaderModule(dev, module, nullptr);
    vkCheck(r, ("vkCreateComputePipelines(" + shader + ")").c_str());

    VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    ai.descriptorPool = pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &st.set_layout;
    vkCheck(vkAllocateDescriptorSets(dev, &ai, &st.set), "vkAllocateDescriptorSets");
    writeSet(st, bindings);
    return st;
  }

  void writeSet(Stage& st, const std::vector<Binding>& bindings) {
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
      w.dstSet = st.set;
      w.dstBinding = bindings[i].binding;
      w.descriptorCount = static_cast<uint32_t>(bindings[i].items.size());
      w.descriptorType = bindings[i].type();
      if (texel_views[i].empty())
        w.pBufferInfo = infos[i].data();
      else
        w.pTexelBufferView = texel_views[i].data();
      writes.push_back(w);
    }
    vkUpdateDescriptorSets(dev, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
  }

  void destroyStage(Stage& st) {
    if (st.pipeline) vkDestroyPipeline(dev, st.pipeline, nullptr);
    if (st.layout) vkDestroyPipelineLayout(dev, st.layout, nullptr);
    if (st.set_layout) vkDestroyDescriptorSetLayout(dev, st.set_layout, nullptr);
    if (st.set) vkFreeDescriptorSets(dev, pool, 1, &st.set);
    st = Stage{};
  }

  void init() {
    params.validate();
    const int W = size.width, H = size.height;
    if (W < 1 || H < 1) throw std::invalid_argument("StereoMatcher: empty image size");
    if (W > kMaxWidth) throw std::invalid_argument("StereoMatcher: width above 4096");
    if (params.aggregation == "rows" && !ctx.supportsRowLayout())
      throw std::invalid_argument(
          "StereoMatcher: aggregation 'rows' needs shaderInt64 and "
          "shaderStorageImageExtendedFormats, which this device lacks");
    rows = params.aggregation == "rows" ||
           (params.aggregation == "auto" && ctx.info().type == "cpu" && ctx.supportsRowLayout());

    const size_t pixels = static_cast<size_t>(W) * H;
    for (int i = 0; i < 2; ++i) {
      image[i] = createBuffer((pixels + 3) / 4 * 4, true);
      census[i] = createBuffer(pixels * 4, false);
      disp[i] = createBuffer(pixels * 4, true);
      median[i] = createBuffer(pixels * 4, true);
    }
    final_disp = createBuffer(pixels * 4, true);
    filled_disp = createBuffer(pixels * 4, true);

    VkDescriptorPoolSize ps[3] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 10 * kMaxChunks + 64},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER, 48},
                                  {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 4}};
    VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    pi.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    pi.maxSets = 24;
    pi.poolSizeCount = 3;
    pi.pPoolSizes = ps;
    vkCheck(vkCreateDescriptorPool(dev, &pi, nullptr, &pool), "vkCreateDescriptorPool");

    image_words[0] = createView(image[0], VK_FORMAT_R32_UINT);
    image_words[1] = createView(image[1], VK_FORMAT_R32_UINT);
    const VkBufferView disp_views[2] = {createView(disp[0], VK_FORMAT_R32_SINT),
                                        createView(disp[1], VK_FORMAT_R32_SINT)};
    census_stage = createStage(
        "census5x5", {{0, image_words[0]}, {1, image_words[1]}, {2, {&census[0]}}, {3, {&census[1]}}}, 8, false);
    if (params.cost == "mi") initMutualInformation();
    if (rows)
      initRows();
    else
      initLines();
    if (params.cost != "census") initCostStages();
    median_stage = createStage(
        "median3x3", {{0, disp_views[0]}, {1, disp_views[1]}, {2, {&median[0]}}, {3, {&median[1]}}}, 8, false);
    const Buffer* lr_in = params.median ? median : disp;
    lr_stage = createStage("lr_check", {{0, {&lr_in[0]}}, {1, {&lr_in[1]}}, {2, {&final_disp}}}, 12, false);
    fill_stage = createStage("fill_invalid", {{0, {&checkedLeft()}}, {1, {&filled_disp}}}, 8, false);
    if (params.cost == "mi" && params.mi_levels > 1 && !is_level) initLevels();
    if (is_level) return;  // records into the top level's command buffer

    VkCommandPoolCreateInfo ci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    ci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    ci.queueFamilyIndex = ctx.queueFamily();
    vkCheck(vkCreateCommandPool(dev, &ci, nullptr, &cmd_pool), "vkCreateCommandPool");
    VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    cai.commandPool = cmd_pool;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    vkCheck(vkAllocateCommandBuffers(dev, &cai, &cmd), "vkAllocateCommandBuffers");
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    vkCheck(vkCreateFence(dev, &fi, nullptr, &fence), "vkCreateFence");
    if (ctx.timestampsSupported()) {
      VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
      qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
      qi.queryCount = kMaxTimestamps;
      vkCheck(vkCreateQueryPool(dev, &qi, nullptr, &queries), "vkCreateQueryPool");
    }
  }

  // The disparities each subgroup lane owns (K, a multiple of `multiple`) and the padded range.
  void laneLayout(int multiple) {
    const int sg = static_cast<int>(ctx.subgroupSize());
    lane_disps = (params.num_disparities + sg - 1) / sg;
    lane_disps = (lane_disps + multiple - 1) / multiple * multiple;
    padded_disps = lane_disps * sg;
  }

  // kMaxChunks storage-buffer ranges over a buffer of `rows` rows, rows_per_chunk rows each (the last repeated).
  static std::vector<Descriptor> rowRanges(const Buffer& buffer, uint64_t row_bytes, int rows, int rows_per_chunk) {
    const int count = (rows + rows_per_chunk - 1) / rows_per_chunk;
    std::vector<Descriptor> ranges;
    for (int i = 0; i < kMaxChunks; ++i) {
      const uint64_t first_row = static_cast<uint64_t>(std::min(i, count - 1)) * rows_per_chunk;
      const uint64_t rows_here = std::min<uint64_t>(rows_per_chunk, rows - first_row);
      ranges.push_back({buffer.buffer, first_row * row_bytes, rows_here * row_bytes, VK_NULL_HANDLE});
    }
    return ranges;
  }

  // Lines: costs stored once in a slice of the volume, one dispatch per path, one subgroup per image line, each
  // path's costs in its own slice (one byte per disparity), summed by sgm_wta.
  void initLines() {
    const int W = size.width, H = size.height;
    laneLayout(4);
    const uint64_t row_bytes = static_cast<uint64_t>(W) * padded_disps;
    row_words = static_cast<int>(row_bytes / 4);
    const uint64_t max_range = std::min<uint64_t>(ctx.maxStorageBufferRange(), 1ull << 31);
    if (row_bytes > max_range) throw std::invalid_argument("StereoMatcher: one row of path costs exceeds a buffer");
    const int total_rows = (params.paths + 1) * H;  // path slices, then the matching-cost slice
    const int max_rows = static_cast<int>(max_range / row_bytes);
    num_chunks = (total_rows + max_rows - 1) / max_rows;
    if (num_chunks > kMaxChunks)
      throw std::invalid_argument("StereoMatcher: path-cost volume too large for " + std::to_string(kMaxChunks) +
                                  " buffers of maxStorageBufferRange (reduce size or num_disparities)");
    rows_per_chunk = (total_rows + num_chunks - 1) / num_chunks;
    for (int c = 0; c < num_chunks; ++c) {
      const int rows_here = std::min(rows_per_chunk, total_rows - c * rows_per_chunk);
      volume.push_back(createBuffer(static_cast<uint64_t>(rows_here) * row_bytes, false));
    }
    std::vector<const Buffer*> chunks;
    for (int i = 0; i < kMaxChunks; ++i) chunks.push_back(&volume[std::min<int>(i, num_chunks - 1)]);
    for (const Buffer* b : chunks) cost_chunks.push_back({b->buffer, 0, VK_WHOLE_SIZE, VK_NULL_HANDLE});
    cost_base_row = params.paths * H;  // the cost slice
    cost_rows_per_chunk = rows_per_chunk;
    cost_row_words = row_words;
    const bool second_match = params.right_map == "match";
    for (int m = 0; m < (second_match ? 2 : 1); ++m) {
      // The second match reads the images swapped (and mirrored, in the shaders) and its left map is the right one.
      const Variant variant{0, m == 1, !second_match};
      MatchStages& st = m == 0 ? left_match : right_match;
      if (params.cost == "census")
        st.cost =
            createStage("cost_census", {{2, {&census[m]}}, {3, {&census[1 - m]}}, {4, chunks}}, 28, true, variant);
      st.aggregate = createStage("sgm_aggregate", {{0, {&image[m]}}, {4, chunks}}, 52, true, variant);
      st.wta = createStage("sgm_wta", {{4, chunks}, {5, {&disp[m]}}, {6, {&disp[1]}}}, 36, true, variant);
    }
  }

  // Rows: two row passes (forward, backward) with the costs computed on the fly and the winner-takes-all fused in:
  // each stores the sums of its paths (16 bits per disparity) for half the rows and selects on the other half,
  // reading the other pass's sums as texels. See sgm_aggregate_rowpass.comp.
  void initRows() {
    const int W = size.width, H = size.height;
    laneLayout(8);
    const uint64_t sum_row_bytes = static_cast<uint64_t>(W) * padded_disps * 2;
    const uint64_t sum_bytes = sum_row_bytes * H;
    const uint64_t max_range = std::min<uint64_t>(ctx.maxStorageBufferRange(), 1ull << 31);
    if (sum_bytes > ctx.maxAllocationBytes() || sum_bytes / 16 > ctx.maxTexelBufferElements())
      throw std::invalid_argument("StereoMatcher: the sums of " + std::to_string(sum_bytes >> 20) +
                                  " MiB exceed one allocation of this device (reduce size or num_disparities)");
    rows_per_chunk = static_cast<int>(max_range / sum_row_bytes);
    num_chunks = rows_per_chunk < 1 ? kMaxChunks + 1 : (H + rows_per_chunk - 1) / rows_per_chunk;
    if (num_chunks > kMaxChunks)
      throw std::invalid_argument("StereoMatcher: sums too large for " + std::to_string(kMaxChunks) +
                                  " storage buffer ranges (reduce size or num_disparities)");
    sums = createBuffer(sum_bytes, false);
    scratch = createBuffer(static_cast<uint64_t>(2 * 2 * 3) * W * padded_disps, false);
    const std::vector<Descriptor> chunks = rowRanges(sums, sum_row_bytes, H, rows_per_chunk);
    const VkBufferView scratch16 = createView(scratch, VK_FORMAT_R32G32B32A32_UINT);
    const VkBufferView scratch8 = createView(scratch, VK_FORMAT_R32G32_UINT);
    const VkBufferView sums_texels = createView(sums, VK_FORMAT_R32G32B32A32_UINT);
    VkBufferView cost_views[2] = {scratch16, scratch8};  // the cost volume as texels (census: unused)
    const bool cost_volume = params.cost != "census";
    if (cost_volume) {
      // The cost volume [y][x][lane][K bytes], written by the cost stage through storage-buffer ranges and read
      // by the row passes as texels.
      const uint64_t cost_row_bytes = static_cast<uint64_t>(W) * padded_disps;
      costs = createBuffer(cost_row_bytes * H, false);
      cost_rows_per_chunk = static_cast<int>(max_range / cost_row_bytes);
      cost_row_words = static_cast<int>(cost_row_bytes / 4);
      cost_chunks = rowRanges(costs, cost_row_bytes, H, cost_rows_per_chunk);
      cost_views[0] = createView(costs, VK_FORMAT_R32G32B32A32_UINT);
      cost_views[1] = createView(costs, VK_FORMAT_R32G32_UINT);
    }
    const bool second_match = params.right_map == "match";
    for (int m = 0; m < (second_match ? 2 : 1); ++m) {
      // The second match reads the images swapped (and mirrored, in the shader) and its left map is the right one.
      const std::vector<Binding> bindings = {{0, createView(image[m], VK_FORMAT_R8_UINT)},
                                             {1, createView(census[m], VK_FORMAT_R32_UINT)},
                                             {2, createView(census[1 - m], VK_FORMAT_R32_UINT)},
                                             {3, scratch16},
                                             {4, scratch8},
                                             {5, {&scratch}},
                                             {6, chunks},
                                             {7, sums_texels},
                                             {8, {&disp[m]}},
                                             {9, {&disp[1]}},
                                             {10, cost_views[0]},
                                             {11, cost_views[1]}};
      MatchStages& st = m == 0 ? left_match : right_match;
      st.aggregate = createStage("sgm_aggregate_rowpass", bindings, sizeof(RowPassParams), true,
                                 {0, m == 1, !second_match, cost_volume});
      st.wta = createStage("sgm_aggregate_rowpass", bindings, sizeof(RowPassParams), true,
                           {1, m == 1, !second_match, cost_volume});
    }
  }

  // The cost stage of each match for the costs other than census (cost_ad, cost_sad, cost_mi): they write the cost
  // volume of the row layout or the cost slice of the line layout.
  void initCostStages() {
    const bool second_match = params.right_map == "match";
    for (int m = 0; m < (second_match ? 2 : 1); ++m) {
      std::vector<Binding> bindings = {{0, image_words[m]}, {1, image_words[1 - m]}, {4, cost_chunks}};
      if (params.cost == "mi") bindings.push_back(Binding::uniformBuffer(5, mi_table_buffer));
      (m == 0 ? left_match : right_match).cost =
          createStage("cost_" + params.cost, bindings, 28, true, {0, m == 1, !second_match});
    }
  }

  // Mutual Information: the histogram from this level's start disparity or own checked map (mode 0, 1) and the
  // table (mi_table.comp). The histogram from the level below is wired by the top level (initLevels).
  void initMutualInformation() {
    mi_histogram = createBuffer((65536 + 1) * 4, false);
    mi_table_buffer = createBuffer(65536, false);
    mi_work64 = createBuffer(65536 * 8, false);
    mi_work32 = createBuffer(2 * 65536 * 4, false);
    mi_log2 = createBuffer(256 * 4, true);
    std::memcpy(mi_log2.mapped, log2FractionTable().data(), 256 * 4);
    mi_start_histogram =
        createStage("mi_histogram",
                    {{0, image_words[0]}, {1, image_words[1]}, {2, {&checkedLeft()}}, {3, {&mi_histogram}}}, 28, false);
    mi_table_stage = createStage(
        "mi_table",
        {{0, {&mi_histogram}}, {1, {&mi_log2}}, {2, {&mi_work64}}, {3, {&mi_work32}}, {4, {&mi_table_buffer}}}, 4,
        false);  // (no push constants: 4 bytes, the smallest range)
  }

  // The coarser levels of the Mutual Information hierarchy (half size each, the level's search range, no fill):
  // each reads the images of the level above it and learns its table from the level below it.
  void initLevels() {
    Impl* above = this;
    cv::Size level_size = size;
    for (int l = 1; l < params.mi_levels; ++l) {
      level_size = cv::Size((level_size.width + 1) / 2, (level_size.height + 1) / 2);
      SgmParams lp = params;
      levelRange(params.min_disparity, params.num_disparities, l, lp.min_disparity, lp.num_disparities);
      lp.mi_levels = 1;
      lp.fill_invalid = false;
      auto level = std::make_unique<Impl>(ctx, level_size, lp);
      level->is_level = true;
      level->init();
      level->downsample_stage = level->createStage(
          "downsample",
          {{0, above->image_words[0]}, {1, above->image_words[1]}, {2, {&level->image[0]}}, {3, {&level->image[1]}}},
          16, false);
      above = level.get();
      levels.push_back(std::move(level));
    }
    // Each level but the coarsest learns from the one below it.
    for (size_t l = 0; l < levels.size(); ++l) {
      Impl& target = l == 0 ? *this : *levels[l - 1];
      const Impl& below = *levels[l];
      target.mi_guided_histogram = target.createStage("mi_histogram",
                                                      {{0, target.image_words[0]},
                                                       {1, target.image_words[1]},
                                                       {2, {&below.checkedLeft()}},
                                                       {3, {&target.mi_histogram}}},
                                                      28, false);
      target.guide_size = below.size;
    }
  }

  // Records the Mutual Information table of this level: the histogram (mode 0 from the start disparity, 1 from this
  // level's checked map, 2 from the checked map of the level below, doubled), then the table.
  void recordMiTable(int mode) {
    vkCmdFillBuffer(cmd, mi_histogram.buffer, 0, VK_WHOLE_SIZE, 0);
    VkMemoryBarrier fill{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    fill.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    fill.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &fill, 0,
                         nullptr, 0, nullptr);
    const Stage& stage = mode == 2 ? mi_guided_histogram : mi_start_histogram;
    bind(stage);
    const int32_t pc[7] = {size.width, size.height,          guide_size.width,      guide_size.height,
                           mode,       params.min_disparity, params.num_disparities};
    push(stage, pc);
    vkCmdDispatch(cmd, groups(size.width, 64), static_cast<uint32_t>(size.height), 1);
    barrier(cmd);
    bind(mi_table_stage);
    vkCmdDispatch(cmd, 1, 1, 1);
    barrier(cmd);
  }

  // Push constants of sgm_aggregate_rowpass.comp.
  struct RowPassParams {
    int32_t width, height, p1, p2, p2_slope, rows_per_chunk, uniqueness, subpixel;
    int32_t begin[2], end[2];
  };

  // Records one phase of the row passes: phase 0 (aggregate_stage) the forward pass on the rows above `split` and
  // the backward pass on the rest, both storing sums; phase 1 (wta_stage) each on the other part, selecting. Each in
  // dispatches of at most kMaxLoopIterations loop iterations per invocation.
  void recordRowPasses(const MatchStages& stages, int phase) {
    const int W = size.width, H = size.height, sg = static_cast<int>(ctx.subgroupSize());
    const int split = H / 2;
    const int row_cost = W + 4 + (std::abs(params.min_disparity) + params.num_disparities) / sg;  // loop iterations
    const int rows_per_dispatch = std::max(1, kMaxLoopIterations / row_cost);
    RowPassParams pc{W,
                     H,
                     params.p1,
                     params.p2,
                     params.p2_slope,
                     rows_per_chunk,
                     params.uniqueness,
                     params.subpixel ? 1 : 0,
                     {0, 0},
                     {0, 0}};
    // Walk rows (forward: image row i, backward: image row H - 1 - i) of the two phases.
    const int phase_begin[2][2] = {{0, 0}, {split, H - split}};
    const int phase_end[2][2] = {{split, H - split}, {H, H}};
    const Stage& stage = phase == 0 ? stages.aggregate : stages.wta;
    bind(stage);
    for (int part = 0;; ++part) {
      bool any = false;
      for (int p = 0; p < 2; ++p) {
        pc.begin[p] = std::min(phase_begin[phase][p] + part * rows_per_dispatch, phase_end[phase][p]);
        pc.end[p] = std::min(pc.begin[p] + rows_per_dispatch, phase_end[phase][p]);
        any = any || pc.end[p] > pc.begin[p];
      }
      if (!any) break;
      push(stage, pc);
      vkCmdDispatch(cmd, 2, 1, 1);
      barrier(cmd);
    }
  }

  // Records one match (cost, aggregation, winner-takes-all) with the given stages; `label` prefixes the stage
  // names of the timing.
  template <typename Timestamp>
  void recordMatch(const MatchStages& st, Timestamp& timestamp, const std::string& label) {
    const int W = size.width, H = size.height;
    auto stamp = [&](const char* name) { timestamp((label + name).c_str()); };
    if (st.cost.pipeline) {  // lines: census into the cost slice; rows and lines: the other costs
      bind(st.cost);
      const bool census_slice = params.cost == "census";
      const int32_t pc[7] = {W,
                             H,
                             params.num_disparities,
                             params.min_disparity,
                             census_slice ? params.paths : cost_base_row,
                             census_slice ? rows_per_chunk : cost_rows_per_chunk,
                             census_slice ? row_words : cost_row_words};
      push(st.cost, pc);
      vkCmdDispatch(cmd, static_cast<uint32_t>(H), 1, 1);
      barrier(cmd);
      stamp("cost");
    }
    if (rows) {
      recordRowPasses(st, 0);
      stamp("aggregate");
      recordRowPasses(st, 1);
      stamp("aggregate_select");
      return;
    }
    bind(st.aggregate);
    const int dirs[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, -1}, {1, -1}, {-1, 1}};
    for (int r = 0; r < params.paths; ++r) {
      const int dx = dirs[r][0], dy = dirs[r][1];
      const int32_t pa[13] = {W,           H,         params.num_disparities, params.min_disparity,
                              params.p1,   params.p2, params.p2_slope,        r,
                              dx,          dy,        rows_per_chunk,         row_words,
                              params.paths};
      push(st.aggregate, pa);
      const int lines = dy == 0 ? H : (dx == 0 ? W : W + H - 1);
      vkCmdDispatch(cmd, static_cast<uint32_t>(lines), 1, 1);
    }
    barrier(cmd);
    stamp("aggregate");
    bind(st.wta);
    const int32_t pw[9] = {W,
                           H,
                           params.num_disparities,
                           params.min_disparity,
                           params.paths,
                           params.uniqueness,
                           params.subpixel ? 1 : 0,
                           rows_per_chunk,
                           row_words};
    push(st.wta, pw);
    vkCmdDispatch(cmd, static_cast<uint32_t>(H), 1, 1);
    barrier(cmd);
    stamp("wta");
  }
  ~Impl() {
    if (dev == VK_NULL_HANDLE) return;
    vkDeviceWaitIdle(dev);
    for (Stage* s : {&census_stage, &left_match.cost, &left_match.aggregate, &left_match.wta, &right_match.cost,
                     &right_match.aggregate, &right_match.wta, &median_stage, &lr_stage, &fill_stage, &rectify_stage,
                     &mi_start_histogram, &mi_guided_histogram, &mi_table_stage, &downsample_stage})
      destroyStage(*s);
    if (pool) vkDestroyDescriptorPool(dev, pool, nullptr);
    if (queries) vkDestroyQueryPool(dev, queries, nullptr);
    if (fence) vkDestroyFence(dev, fence, nullptr);
    if (cmd_pool) vkDestroyCommandPool(dev, cmd_pool, nullptr);
    for (VkBufferView v : views) vkDestroyBufferView(dev, v, nullptr);
    for (int i = 0; i < 2; ++i)
      for (Buffer* b : {&image[i], &census[i], &disp[i], &median[i], &raw[i]}) destroyBuffer(*b);
    destroyBuffer(scratch);
    destroyBuffer(sums);
    for (Buffer* b : {&costs, &mi_histogram, &mi_table_buffer, &mi_work64, &mi_work32, &mi_log2}) destroyBuffer(*b);
    destroyBuffer(final_disp);
    destroyBuffer(filled_disp);
    destroyBuffer(maps);
    for (auto& b : volume) destroyBuffer(b);
  }

  // The left map after median and LR check (whichever of them are enabled), before the optional fill.
  const Buffer& checkedLeft() const {
    return params.lr_max_diff >= 0 ? final_disp : (params.median ? median[0] : disp[0]);
  }

  static void barrier(VkCommandBuffer c) {
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    vkCmdPipelineBarrier(c, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &mb, 0,
                         nullptr, 0, nullptr);
  }

  void bind(const Stage& st) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, st.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, st.layout, 0, 1, &st.set, 0, nullptr);
  }

  template <typename T>
  void push(const Stage& st, const T& values) {
    vkCmdPushConstants(cmd, st.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(T), &values);
  }

  static uint32_t groups(int n, int local) { return static_cast<uint32_t>((n + local - 1) / local); }

  // Records the matching of this level once its images (and, for mi, its table) are in place: the census (census
  // cost), each match (the left one, and the mirrored second one for right_map "match"), the median and the
  // left-right check; not the fill.
  template <typename Timestamp>
  void recordMatching(Timestamp& timestamp) {
    const int W = size.width, H = size.height;
    // census5x5 and median3x3: one invocation per column strip of kStrip rows, both images or maps (z).
    auto strips = [&](const Stage& st) {
      bind(st);
      const int32_t pc[2] = {W, H};
      push(st, pc);
      vkCmdDispatch(cmd, groups(W, 64), groups(H, kStrip), 2);
      barrier(cmd);
    };
    if (params.cost == "census") {
      strips(census_stage);
      timestamp("census");
    }
    recordMatch(left_match, timestamp, "");
    if (params.right_map == "match") recordMatch(right_match, timestamp, "right_");
    if (params.median) {
      strips(median_stage);
      timestamp("median");
    }
    if (params.lr_max_diff >= 0) {
      bind(lr_stage);
      const int32_t pc[3] = {W, H, params.lr_max_diff * kSubpixelScale};
      push(lr_stage, pc);
      vkCmdDispatch(cmd, groups(W, 16), groups(H, 8), 1);
      barrier(cmd);
      timestamp("lr_check");
    }
  }

  // Records the Mutual Information hierarchy: the pyramid, the coarsest level from the start disparity
  // (mi_coarse_iterations times, each learning from the one before), each finer level from the level below, and
  // this level (the finest) last.
  template <typename Timestamp>
  void recordHierarchy(Timestamp& timestamp) {
    if (!levels.empty()) {
      const Impl* above = this;
      for (auto& level : levels) {
        level->cmd = cmd;
        level->bind(level->downsample_stage);
        const int32_t pc[4] = {above->size.width, above->size.height, level->size.width, level->size.height};
        level->push(level->downsample_stage, pc);
        vkCmdDispatch(cmd, groups((level->size.area() + 3) / 4, 64), 1, 2);
        barrier(cmd);
        above = level.get();
      }
      timestamp("pyramid");
      auto none = [](const char*) {};
      for (int l = static_cast<int>(levels.size()) - 1; l >= 0; --l) {
        Impl& level = *levels[l];
        const bool coarsest = l + 1 == static_cast<int>(levels.size());
        for (int it = 0; it < (coarsest ? params.mi_coarse_iterations : 1); ++it) {
          level.recordMiTable(coarsest ? (it == 0 ? 0 : 1) : 2);
          level.recordMatching(none);
        }
        timestamp(("mi_level" + std::to_string(l + 1)).c_str());
      }
    }
    for (int it = 0; it < (levels.empty() ? params.mi_coarse_iterations : 1); ++it) {
      recordMiTable(levels.empty() ? (it == 0 ? 0 : 1) : 2);
      timestamp("mi_table");
      recordMatching(timestamp);
    }
  }

  MatchOutput run(bool rectify, bool want_right) {
    const auto t0 = std::chrono::steady_clock::now();
    const int W = size.width, H = size.height;
    std::vector<std::string> names;
    uint32_t stamp = 0;
    auto timestamp = [&](const char* name) {
      if (!queries || stamp >= kMaxTimestamps) return;
      vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries, stamp++);
      if (name) names.push_back(name);
    };

    vkCheck(vkResetCommandBuffer(cmd, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkCheck(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer");
    if (queries) vkCmdResetQueryPool(cmd, queries, 0, kMaxTimestamps);
    timestamp(nullptr);
    if (rectify) {
      bind(rectify_stage);
      const int32_t pc[4] = {W, H, raw_size.width, raw_size.height};
      push(rectify_stage, pc);
      vkCmdDispatch(cmd, groups((W * H + 3) / 4, 64), 1, 2);
      barrier(cmd);
      timestamp("rectify");
    }
    if (params.cost == "mi") {
      recordHierarchy(timestamp);
    } else {
      recordMatching(timestamp);
    }
    if (params.fill_invalid) {
      bind(fill_stage);
      const int32_t pc[2] = {W, H};
      push(fill_stage, pc);
      vkCmdDispatch(cmd, groups(H, 64), 1, 1);
      timestamp("fill");
    }
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &mb, 0, nullptr,
                         0, nullptr);
    vkCheck(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");

    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    vkCheck(vkResetFences(dev, 1, &fence), "vkResetFences");
    vkCheck(vkQueueSubmit(ctx.queue(), 1, &si, fence), "vkQueueSubmit");
    vkCheck(vkWaitForFences(dev, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");

    MatchOutput out;
    if (queries && stamp > 1) {
      std::vector<uint64_t> ticks(stamp);
      vkCheck(vkGetQueryPoolResults(dev, queries, 0, stamp, ticks.size() * 8, ticks.data(), 8,
                                    VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
              "vkGetQueryPoolResults");
      for (size_t i = 1; i < stamp; ++i) {
        const double ms = static_cast<double>(ticks[i] - ticks[i - 1]) * ctx.timestampPeriodNs() * 1e-6;
        out.stages.push_back({names[i - 1], ms});
        out.device_ms += ms;
      }
    }
    out.disparity = toInt16(params.fill_invalid ? filled_disp : checkedLeft());
    if (want_right) out.right = toInt16(params.median ? median[1] : disp[1]);
    out.total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  cv::Mat toInt16(const Buffer& b) const {
    cv::Mat wrapped(size, CV_32S, b.mapped);
    cv::Mat out;
    wrapped.convertTo(out, CV_16S);
    return out;
  }

  static void upload(Buffer& b, const cv::Mat& img) {
    auto* dst = static_cast<uint8_t*>(b.mapped);
    for (int y = 0; y < img.rows; ++y) std::memcpy(dst + static_cast<size_t>(y) * img.cols, img.ptr(y), img.cols);
  }

  void checkPair(const cv::Mat& a, const cv::Mat& b, cv::Size expected, const char* what) const {
    if (a.empty() || b.empty() || a.type() != CV_8UC1 || b.type() != CV_8UC1)
      throw std::invalid_argument(std::string("StereoMatcher: ") + what + " must be two CV_8UC1 images");
    if (a.size() != expected || b.size() != expected)
      throw std::invalid_argument(std::string("StereoMatcher: ") + what + " must be " + std::to_string(expected.width) +
                                  "x" + std::to_string(expected.height));
  }
};

StereoMatcher::StereoMatcher(VulkanContext& ctx, cv::Size size, const SgmParams& params)
    : impl_(new Impl(ctx, size, params)) {
  impl_->init();
}

StereoMatcher::~StereoMatcher() = default;

MatchOutput StereoMatcher::match(const cv::Mat& left, const cv::Mat& right, bool want_right) {
  impl_->checkPair(left, right, impl_->size, "match input");
  Impl::upload(impl_->image[0], left);
  Impl::upload(impl_->image[1], right);
  return impl_->run(false, want_right);
}

void StereoMatcher::setRectification(const StereoRectification& rect, cv::Size raw_size) {
  Impl& m = *impl_;
  if (rect.size != m.size) throw std::invalid_argument("StereoMatcher::setRectification: rectified size differs");
  const cv::Mat* maps[4] = {&rect.map0x, &rect.map0y, &rect.map1x, &rect.map1y};
  for (const cv::Mat* mp : maps)
    if (mp->type() != CV_32FC1 || mp->size() != m.size)
      throw std::invalid_argument("StereoMatcher::setRectification: maps must be CV_32FC1 of the rectified size");
  if (raw_size.width < 1 || raw_size.height < 1) throw std::invalid_argument("setRectification: empty raw size");
  vkDeviceWaitIdle(m.dev);
  m.destroyStage(m.rectify_stage);
  for (auto* b : {&m.raw[0], &m.raw[1], &m.maps}) m.destroyBuffer(*b);
  const size_t raw_pixels = static_cast<size_t>(raw_size.width) * raw_size.height;
  const size_t n = static_cast<size_t>(m.size.area());
  m.raw[0] = m.createBuffer((raw_pixels + 3) / 4 * 4, true);
  m.raw[1] = m.createBuffer((raw_pixels + 3) / 4 * 4, true);
  m.maps = m.createBuffer(4 * n * sizeof(float), true);
  for (int i = 0; i < 4; ++i) {
    cv::Mat dst(m.size, CV_32F, static_cast<float*>(m.maps.mapped) + i * n);
    maps[i]->copyTo(dst);
  }
  m.raw_size = raw_size;
  m.rectify_stage = m.createStage(
      "rectify", {{0, {&m.raw[0]}}, {1, {&m.raw[1]}}, {2, {&m.maps}}, {3, {&m.image[0]}}, {4, {&m.image[1]}}}, 16,
      false);
  m.has_rect = true;
}

MatchOutput StereoMatcher::matchRaw(const cv::Mat& raw0, const cv::Mat& raw1, cv::Mat* rect0, cv::Mat* rect1,
                                    bool want_right) {
  if (!impl_->has_rect) throw std::logic_error("StereoMatcher::matchRaw: call setRectification first");
  impl_->checkPair(raw0, raw1, impl_->raw_size, "matchRaw input");
  Impl::upload(impl_->raw[0], raw0);
  Impl::upload(impl_->raw[1], raw1);
  MatchOutput out = impl_->run(true, want_right);
  if (rect0) cv::Mat(impl_->size, CV_8UC1, impl_->image[0].mapped).copyTo(*rect0);
  if (rect1) cv::Mat(impl_->size, CV_8UC1, impl_->image[1].mapped).copyTo(*rect1);
  return out;
}

cv::Size StereoMatcher::size() const { return impl_->size; }
const SgmParams& StereoMatcher::params() const { return impl_->params; }
size_t StereoMatcher::deviceMemoryBytes() const {
  size_t bytes = impl_->memory_bytes;
  for (const auto& level : impl_->levels) bytes += level->memory_bytes;
  return bytes;
}

}  // namespace e3d
}  // namespace ips
