// Vulkan ray tracing path: device, buffers, acceleration structures, pipeline, dispatch
// (runner.h). The traversal itself is in shaders/ (GLSL); the records it reads are built
// by records.cpp or read from a baked file. See docs/vulkan.md.
#include "render/vulkan/runner.h"

// Vulkan structs are initialised by their sType alone (the rest zero): not a bug.
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

#include "core/error.h"
#include "core/kernels/device_records.h"

#include <fmt/format.h>
#include <vulkan/vulkan.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace oblong::vk {

using namespace vkgpu;

static_assert(sizeof(RayGpu) == 40 && sizeof(HitGpu) == 32 && sizeof(CountersGpu) == 32);
static_assert(sizeof(TriGpu) == 1560 && sizeof(TriGpu) % 8 == 0 && alignof(TriGpu) == 8);
static_assert(sizeof(MeshGpu) == 176 && sizeof(PushGpu) == 16);
static_assert(sizeof(AabbGpu) == sizeof(VkAabbPositionsKHR) && offsetof(VkAabbPositionsKHR, maxX) == 12,
              "AabbGpu mirrors VkAabbPositionsKHR: the AABB buffer is copied as is");

namespace {

// SPIR-V of the stages, compiled and validated at build time (CMake: glslc, spirv-val).
const uint32_t kRgen[] = {
#include "trace.rgen.inc"
};
const uint32_t kMiss[] = {
#include "trace.rmiss.inc"
};
const uint32_t kRint[] = {
#include "prism.rint.inc"
};
const uint32_t kTfdmRint[] = {
#include "tfdm.rint.inc"
};
// The intersection shader of each traversal the records describe (MeshGpu::method, set
// by records.cpp from the strategies' traits) and the name of its pyramid in the memory
// report.
struct IntersectionProgram {
  int method;
  const char* name;   // the method's name (--method, --baseline)
  const char* stage;  // its shader's file, as the build names it (vulkan_shaders/STAGE.spv)
  const uint32_t* code;
  size_t bytes;
  const char* pyramid;
};
const IntersectionProgram kPrograms[] = {
    {OBLONG_METHOD_CANONICAL, "canonical", "prism.rint", kRint, sizeof kRint, "vulkan/rmip_layers"},
    {OBLONG_METHOD_TFDM, "tfdm", "tfdm.rint", kTfdmRint, sizeof kTfdmRint, "vulkan/tfdm_mipmap"},
};
constexpr size_t kProgramCount = std::size(kPrograms);

const uint32_t kPrismHit[] = {
#include "prism.rchit.inc"
};
const uint32_t kTriangleHit[] = {
#include "triangle.rchit.inc"
};

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) fail("--device vulkan", "{} failed (VkResult {})", what, int(r));
}

VkDeviceSize alignUp(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }

const char* const kDeviceExtensions[] = {VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME,
                                         VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME,
                                         VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME};

struct Buffer {
  VkBuffer buf = VK_NULL_HANDLE;
  VkDeviceMemory mem = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* map = nullptr;
  VkDeviceAddress addr = 0;
};

// One stage's SPIR-V.
struct StageCode {
  const uint32_t* code;
  size_t bytes;
};
// The stages' files as the build names them (vulkan_shaders/NAME.spv), in the pipeline's
// order; the intersection stage's is kPrograms' own.
const char* const kStageFiles[5] = {"trace.rgen", "trace.rmiss", nullptr, "prism.rchit", "triangle.rchit"};

// A ray-tracing pipeline and its shader binding table's regions.
struct Pipeline {
  VkPipeline pipeline = VK_NULL_HANDLE;
  VkStridedDeviceAddressRegionKHR rgenRegion{}, missRegion{}, hitRegion{}, callRegion{};
};

}  // namespace

// The instance, the device, its queue and the pipelines: one per process while any
// Runner (or DeviceHold) holds it (sharedDevice). A scene's buffers, structures and
// descriptor set are its Runner's (SceneOnDevice).
struct Device {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice phys = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t family = 0;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties props{};
  VkPhysicalDeviceRayTracingPipelinePropertiesKHR rt{};
  VkPhysicalDeviceAccelerationStructurePropertiesKHR asProps{};
  VkPhysicalDeviceMemoryProperties memProps{};
  std::string driverInfo;

  PFN_vkCreateAccelerationStructureKHR createAS = nullptr;
  PFN_vkDestroyAccelerationStructureKHR destroyAS = nullptr;
  PFN_vkGetAccelerationStructureBuildSizesKHR buildSizes = nullptr;
  PFN_vkCmdBuildAccelerationStructuresKHR cmdBuildAS = nullptr;
  PFN_vkGetAccelerationStructureDeviceAddressKHR asAddress = nullptr;
  PFN_vkCreateRayTracingPipelinesKHR createPipelines = nullptr;
  PFN_vkGetRayTracingShaderGroupHandlesKHR groupHandles = nullptr;
  PFN_vkCmdTraceRaysKHR cmdTraceRays = nullptr;
  // VK_KHR_pipeline_executable_properties, enabled only on a device made for
  // pipelineStatistics (where the device has it): the timed runs' device stays as it was.
  bool executableInfo = false;
  PFN_vkGetPipelineExecutablePropertiesKHR executableProps = nullptr;
  PFN_vkGetPipelineExecutableStatisticsKHR executableStats = nullptr;

  std::vector<Buffer> buffers;  // the shader binding tables, freed in the destructor
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout pipeLayout = VK_NULL_HANDLE;
  Pipeline pipelines[kProgramCount];  // one per kPrograms row: created at first use, then shared by every scene
  std::vector<VkShaderModule> modules;
  VkQueryPool timestamps = VK_NULL_HANDLE;  // 2 queries around each dispatch (none: no timestamps)
  uint32_t timestampBits = 0;
  // One submission (and its timestamp queries) at a time: scenes share the queue, the
  // fence and the query pool.
  std::mutex mutex;

  explicit Device(bool wantExecutableInfo = false) {
    try {  // a constructor that throws runs no destructor: release what was created
      create(wantExecutableInfo);
    } catch (...) {
      destroy();
      throw;
    }
  }
  ~Device() { destroy(); }

  void create(bool wantExecutableInfo) {
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "oblong";
    app.apiVersion = VK_API_VERSION_1_2;
    VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    ici.pApplicationInfo = &app;
    // OBLONG_VULKAN_VALIDATION=1 enables the Khronos validation layer (when installed).
    const char* layer = "VK_LAYER_KHRONOS_validation";
    if (const char* v = std::getenv("OBLONG_VULKAN_VALIDATION"); v && std::string(v) == "1") {
      ici.enabledLayerCount = 1;
      ici.ppEnabledLayerNames = &layer;
    }
    const VkResult r = vkCreateInstance(&ici, nullptr, &instance);
    if (r == VK_ERROR_INCOMPATIBLE_DRIVER || r == VK_ERROR_INITIALIZATION_FAILED)
      fail("--device vulkan", "no Vulkan driver found (lavapipe: mesa-vulkan-drivers from bookworm-backports, "
                              "installed by scripts/setup.sh)");
    check(r, "vkCreateInstance");
    pickDevice();
    createDevice(wantExecutableInfo);
    createLayouts();
  }

  // The first device (discrete GPUs first, the CPU's lavapipe last) with the ray tracing
  // extensions and the features the shaders need.
  void pickDevice() {
    uint32_t n = 0;
    vkEnumeratePhysicalDevices(instance, &n, nullptr);
    std::vector<VkPhysicalDevice> devs(n);
    vkEnumeratePhysicalDevices(instance, &n, devs.data());
    auto rank = [](VkPhysicalDeviceType t) {
      switch (t) {
        case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
        case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
        case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
        case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
        default: return 4;
      }
    };
    std::string seen;
    int best = 99;
    for (VkPhysicalDevice d : devs) {
      VkPhysicalDeviceProperties p;
      vkGetPhysicalDeviceProperties(d, &p);
      seen += fmt::format("{}{}", seen.empty() ? "" : ", ", p.deviceName);
      uint32_t ne = 0;
      vkEnumerateDeviceExtensionProperties(d, nullptr, &ne, nullptr);
      std::vector<VkExtensionProperties> ext(ne);
      vkEnumerateDeviceExtensionProperties(d, nullptr, &ne, ext.data());
      bool ok = p.apiVersion >= VK_API_VERSION_1_2;
      for (const char* want : kDeviceExtensions)
        ok = ok && std::any_of(ext.begin(), ext.end(), [&](const VkExtensionProperties& e) {
               return std::strcmp(e.extensionName, want) == 0;
             });
      if (!ok) continue;
      VkPhysicalDeviceRayTracingPipelineFeaturesKHR rtf{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR};
      VkPhysicalDeviceAccelerationStructureFeaturesKHR asf{
          VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR, &rtf};
      VkPhysicalDeviceVulkan12Features v12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &asf};
      VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v12};
      vkGetPhysicalDeviceFeatures2(d, &f2);
      if (!rtf.rayTracingPipeline || !asf.accelerationStructure || !v12.bufferDeviceAddress ||
          !v12.scalarBlockLayout || !f2.features.shaderFloat64 || !v12.shaderStorageBufferArrayNonUniformIndexing)
        continue;
      if (rank(p.deviceType) < best) best = rank(p.deviceType), phys = d;
    }
    if (!phys)
      fail("--device vulkan", "no Vulkan device supports ray tracing (needs VK_KHR_ray_tracing_pipeline, "
                              "VK_KHR_acceleration_structure, shaderFloat64, scalar block layout, non-uniform "
                              "storage-buffer indexing); devices: {}",
           seen.empty() ? "none" : seen);
    vkGetPhysicalDeviceProperties(phys, &props);
    rt.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR;
    asProps.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR;
    asProps.pNext = &rt;
    VkPhysicalDeviceDriverProperties drv{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES, &asProps};
    VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &drv};
    vkGetPhysicalDeviceProperties2(phys, &p2);
    driverInfo = fmt::format("{} {}", drv.driverName, drv.driverInfo);
    vkGetPhysicalDeviceMemoryProperties(phys, &memProps);
  }

  bool hasExtension(const char* name) const {
    uint32_t ne = 0;
    vkEnumerateDeviceExtensionProperties(phys, nullptr, &ne, nullptr);
    std::vector<VkExtensionProperties> ext(ne);
    vkEnumerateDeviceExtensionProperties(phys, nullptr, &ne, ext.data());
    return std::any_of(ext.begin(), ext.end(),
                       [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
  }

  void createDevice(bool wantExecutableInfo) {
    uint32_t nq = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(phys, &nq, nullptr);
    std::vector<VkQueueFamilyProperties> qf(nq);
    vkGetPhysicalDeviceQueueFamilyProperties(phys, &nq, qf.data());
    family = UINT32_MAX;
    for (uint32_t i = 0; i < nq && family == UINT32_MAX; ++i)
      if (qf[i].queueFlags & VK_QUEUE_COMPUTE_BIT) family = i;
    if (family == UINT32_MAX) fail("--device vulkan", "{}: no compute queue", props.deviceName);
    timestampBits = qf[family].timestampValidBits;
    const float prio = 1.0f;
    VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    qci.queueFamilyIndex = family;
    qci.queueCount = 1;
    qci.pQueuePriorities = &prio;
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR rtf{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR};
    rtf.rayTracingPipeline = VK_TRUE;
    VkPhysicalDeviceAccelerationStructureFeaturesKHR asf{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR, &rtf};
    asf.accelerationStructure = VK_TRUE;
    VkPhysicalDeviceVulkan12Features v12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &asf};
    v12.bufferDeviceAddress = VK_TRUE;
    v12.scalarBlockLayout = VK_TRUE;
    v12.shaderStorageBufferArrayNonUniformIndexing = VK_TRUE;
    VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR exf{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR};
    std::vector<const char*> extensions(std::begin(kDeviceExtensions), std::end(kDeviceExtensions));
    if (wantExecutableInfo && hasExtension(VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME)) {
      VkPhysicalDeviceFeatures2 q{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &exf};
      vkGetPhysicalDeviceFeatures2(phys, &q);
      executableInfo = exf.pipelineExecutableInfo == VK_TRUE;
    }
    if (executableInfo) {
      extensions.push_back(VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
      exf.pNext = &v12;
    }
    VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
                                 executableInfo ? static_cast<void*>(&exf) : static_cast<void*>(&v12)};
    f2.features.shaderFloat64 = VK_TRUE;
    VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &f2};
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    dci.enabledExtensionCount = uint32_t(extensions.size());
    dci.ppEnabledExtensionNames = extensions.data();
    check(vkCreateDevice(phys, &dci, nullptr, &device), "vkCreateDevice");
    vkGetDeviceQueue(device, family, 0, &queue);
    auto load = [&](auto& fn, const char* name) {
      fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(vkGetDeviceProcAddr(device, name));
      if (!fn) fail("--device vulkan", "{}: missing entry point {}", props.deviceName, name);
    };
    load(createAS, "vkCreateAccelerationStructureKHR");
    load(destroyAS, "vkDestroyAccelerationStructureKHR");
    load(buildSizes, "vkGetAccelerationStructureBuildSizesKHR");
    load(cmdBuildAS, "vkCmdBuildAccelerationStructuresKHR");
    load(asAddress, "vkGetAccelerationStructureDeviceAddressKHR");
    load(createPipelines, "vkCreateRayTracingPipelinesKHR");
    load(groupHandles, "vkGetRayTracingShaderGroupHandlesKHR");
    load(cmdTraceRays, "vkCmdTraceRaysKHR");
    if (executableInfo) {
      load(executableProps, "vkGetPipelineExecutablePropertiesKHR");
      load(executableStats, "vkGetPipelineExecutableStatisticsKHR");
    }
    VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pci.queueFamilyIndex = family;
    check(vkCreateCommandPool(device, &pci, nullptr, &pool), "vkCreateCommandPool");
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    check(vkCreateFence(device, &fci, nullptr, &fence), "vkCreateFence");
    if (timestampBits) {
      VkQueryPoolCreateInfo qpci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
      qpci.queryType = VK_QUERY_TYPE_TIMESTAMP;
      qpci.queryCount = 2;
      check(vkCreateQueryPool(device, &qpci, nullptr, &timestamps), "vkCreateQueryPool");
    }
  }

  void destroy() {
    if (device) {
      vkDeviceWaitIdle(device);
      freeBuffers(buffers);
      for (VkShaderModule m : modules) vkDestroyShaderModule(device, m, nullptr);
      for (const Pipeline& p : pipelines)
        if (p.pipeline) vkDestroyPipeline(device, p.pipeline, nullptr);
      if (pipeLayout) vkDestroyPipelineLayout(device, pipeLayout, nullptr);
      if (setLayout) vkDestroyDescriptorSetLayout(device, setLayout, nullptr);
      if (fence) vkDestroyFence(device, fence, nullptr);
      if (timestamps) vkDestroyQueryPool(device, timestamps, nullptr);
      if (pool) vkDestroyCommandPool(device, pool, nullptr);
      vkDestroyDevice(device, nullptr);
    }
    if (instance) vkDestroyInstance(instance, nullptr);
  }

  void freeBuffers(std::vector<Buffer>& owned) {
    for (Buffer& b : owned) {
      vkDestroyBuffer(device, b.buf, nullptr);
      vkFreeMemory(device, b.mem, nullptr);
    }
    owned.clear();
  }

  uint32_t memoryType(uint32_t bits, VkMemoryPropertyFlags need, VkMemoryPropertyFlags prefer) const {
    for (int pass = 0; pass < 2; ++pass)
      for (uint32_t i = 0; i < memProps.memoryTypeCount; ++i) {
        const VkMemoryPropertyFlags f = memProps.memoryTypes[i].propertyFlags;
        if (!(bits & (1u << i)) || (f & need) != need) continue;
        if (pass == 0 && (f & prefer) != prefer) continue;
        return i;
      }
    fail("--device vulkan", "{}: no suitable memory type", props.deviceName);
  }

  // Buffers the host writes are host-visible (device-local too where the device has such
  // memory); buffers it reads back (readback) are host-visible and cached where the
  // device has such memory: a CPU read of device-local memory mapped through the PCIe
  // BAR is uncached, microseconds per hit record on an NVIDIA H200. Acceleration
  // structures and scratch are device-local.
  // The buffer joins `owned` (freed by freeBuffers).
  Buffer makeBuffer(std::vector<Buffer>& owned, VkDeviceSize size, VkBufferUsageFlags usage, bool host,
                    bool readback = false) {
    Buffer b;
    b.size = std::max<VkDeviceSize>(size, 16);
    VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    bci.size = b.size;
    bci.usage = usage | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    check(vkCreateBuffer(device, &bci, nullptr, &b.buf), "vkCreateBuffer");
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device, b.buf, &req);
    VkMemoryAllocateFlagsInfo flags{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
    flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
    VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, &flags};
    mai.allocationSize = req.size;
    mai.memoryTypeIndex =
        host ? memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                          readback ? VK_MEMORY_PROPERTY_HOST_CACHED_BIT : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT)
             : memoryType(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    const VkResult r = vkAllocateMemory(device, &mai, nullptr, &b.mem);
    if (r != VK_SUCCESS) {
      vkDestroyBuffer(device, b.buf, nullptr);
      fail("--device vulkan", "{}: cannot allocate {} bytes (VkResult {})", props.deviceName, req.size, int(r));
    }
    check(vkBindBufferMemory(device, b.buf, b.mem, 0), "vkBindBufferMemory");
    if (host) check(vkMapMemory(device, b.mem, 0, VK_WHOLE_SIZE, 0, &b.map), "vkMapMemory");
    VkBufferDeviceAddressInfo ai{VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO};
    ai.buffer = b.buf;
    b.addr = vkGetBufferDeviceAddress(device, &ai);
    owned.push_back(b);
    return b;
  }

  void submit(const std::function<void(VkCommandBuffer)>& record) {
    VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    cai.commandPool = pool;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    VkCommandBuffer cb;
    check(vkAllocateCommandBuffers(device, &cai, &cb), "vkAllocateCommandBuffers");
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(cb, &bi);
    record(cb);
    vkEndCommandBuffer(cb);
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cb;
    check(vkQueueSubmit(queue, 1, &si, fence), "vkQueueSubmit");
    check(vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    vkResetFences(device, 1, &fence);
    vkFreeCommandBuffers(device, pool, 1, &cb);
  }

  VkDeviceAddress address(VkAccelerationStructureKHR as) const {
    VkAccelerationStructureDeviceAddressInfoKHR ai{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR};
    ai.accelerationStructure = as;
    return asAddress(device, &ai);
  }

  VkShaderModule module(const uint32_t* code, size_t bytes) {
    VkShaderModuleCreateInfo ci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    ci.codeSize = bytes;
    ci.pCode = code;
    VkShaderModule m;
    check(vkCreateShaderModule(device, &ci, nullptr, &m), "vkCreateShaderModule");
    modules.push_back(m);
    return m;
  }

  // The descriptor set's and the pipeline's layouts (one for both pipelines).
  void createLayouts() {
    const VkShaderStageFlags all = VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR |
                                   VK_SHADER_STAGE_INTERSECTION_BIT_KHR | VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR;
    std::vector<VkDescriptorSetLayoutBinding> binds(OBLONG_BIND_COUNT);
    for (uint32_t b = 0; b < OBLONG_BIND_COUNT; ++b) {
      binds[b].binding = b;
      binds[b].descriptorType = b == OBLONG_BIND_TLAS ? VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR
                                                      : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      binds[b].descriptorCount = b == OBLONG_BIND_TEXELS || b == OBLONG_BIND_RMIP_DATA ? OBLONG_CHUNKS : 1;
      binds[b].stageFlags = all;
    }
    VkDescriptorSetLayoutCreateInfo lci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    lci.bindingCount = uint32_t(binds.size());
    lci.pBindings = binds.data();
    check(vkCreateDescriptorSetLayout(device, &lci, nullptr, &setLayout), "vkCreateDescriptorSetLayout");
    VkPushConstantRange pcr{all, 0, sizeof(PushGpu)};
    VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    plci.setLayoutCount = 1;
    plci.pSetLayouts = &setLayout;
    plci.pushConstantRangeCount = 1;
    plci.pPushConstantRanges = &pcr;
    check(vkCreatePipelineLayout(device, &plci, nullptr, &pipeLayout), "vkCreatePipelineLayout");

  }

  // A ray-tracing pipeline of five stages (kStageFiles' order: raygen, miss, intersection,
  // the prism's and the triangles' closest hit) and four groups.
  VkPipeline createPipeline(const StageCode (&code)[5], VkPipelineCreateFlags flags) {
    const VkShaderStageFlagBits kind[5] = {VK_SHADER_STAGE_RAYGEN_BIT_KHR, VK_SHADER_STAGE_MISS_BIT_KHR,
                                           VK_SHADER_STAGE_INTERSECTION_BIT_KHR, VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR,
                                           VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR};
    VkPipelineShaderStageCreateInfo stages[5];
    for (int i = 0; i < 5; ++i) {
      stages[i] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
      stages[i].stage = kind[i];
      stages[i].module = module(code[i].code, code[i].bytes);
      stages[i].pName = "main";
    }
    auto group = [](VkRayTracingShaderGroupTypeKHR type, uint32_t general, uint32_t chit, uint32_t isect) {
      VkRayTracingShaderGroupCreateInfoKHR g{VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR};
      g.type = type;
      g.generalShader = general;
      g.closestHitShader = chit;
      g.anyHitShader = VK_SHADER_UNUSED_KHR;
      g.intersectionShader = isect;
      return g;
    };
    const uint32_t U = VK_SHADER_UNUSED_KHR;
    // Groups: 0 raygen, 1 miss, 2 + OBLONG_HITGROUP_PRISM, 2 + OBLONG_HITGROUP_TRIANGLES.
    const VkRayTracingShaderGroupCreateInfoKHR groups[4] = {
        group(VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR, 0, U, U),
        group(VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR, 1, U, U),
        group(VK_RAY_TRACING_SHADER_GROUP_TYPE_PROCEDURAL_HIT_GROUP_KHR, U, 3, 2),
        group(VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR, U, 4, U)};
    static_assert(OBLONG_HITGROUP_PRISM == 0 && OBLONG_HITGROUP_TRIANGLES == 1);
    VkRayTracingPipelineCreateInfoKHR rpci{VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR};
    rpci.stageCount = 5;
    rpci.pStages = stages;
    rpci.groupCount = 4;
    rpci.pGroups = groups;
    rpci.maxPipelineRayRecursionDepth = 1;
    rpci.layout = pipeLayout;
    rpci.flags = flags;
    VkPipeline pipe = VK_NULL_HANDLE;
    check(createPipelines(device, VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &rpci, nullptr, &pipe),
          "vkCreateRayTracingPipelinesKHR");
    return pipe;
  }

  // The pipeline of kPrograms[program] (its intersection shader, the other stages
  // shared), created at its first use.
  const Pipeline& pipeline(size_t program) {
    if (pipelines[program].pipeline) return pipelines[program];
    const IntersectionProgram& prog = kPrograms[program];
    // Built aside and stored whole: a failure half-way leaves no half-made pipeline to reuse.
    Pipeline P;
    const StageCode code[5] = {{kRgen, sizeof kRgen},
                               {kMiss, sizeof kMiss},
                               {prog.code, prog.bytes},
                               {kPrismHit, sizeof kPrismHit},
                               {kTriangleHit, sizeof kTriangleHit}};
    P.pipeline = createPipeline(code, 0);

    // Shader binding table: raygen | miss | two hit groups, each region base-aligned.
    const VkDeviceSize hs = rt.shaderGroupHandleSize;
    const VkDeviceSize stride = alignUp(hs, rt.shaderGroupHandleAlignment), base = rt.shaderGroupBaseAlignment;
    std::vector<uint8_t> handles(4 * hs);
    const VkDeviceSize rgenSize = alignUp(stride, base), missSize = alignUp(stride, base),
                       hitSize = alignUp(2 * stride, base);
    Buffer sbt;
    try {
      check(groupHandles(device, P.pipeline, 0, 4, handles.size(), handles.data()),
            "vkGetRayTracingShaderGroupHandlesKHR");
      sbt = makeBuffer(buffers, rgenSize + missSize + hitSize + base, VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR,
                       true);
    } catch (...) {
      vkDestroyPipeline(device, P.pipeline, nullptr);
      throw;
    }
    const VkDeviceAddress start = alignUp(sbt.addr, base);
    uint8_t* p = static_cast<uint8_t*>(sbt.map) + (start - sbt.addr);
    std::memcpy(p, &handles[0], hs);
    std::memcpy(p + rgenSize, &handles[hs], hs);
    std::memcpy(p + rgenSize + missSize, &handles[2 * hs], hs);
    std::memcpy(p + rgenSize + missSize + stride, &handles[3 * hs], hs);
    P.rgenRegion = {start, rgenSize, rgenSize};
    P.missRegion = {start + rgenSize, stride, missSize};
    P.hitRegion = {start + rgenSize + missSize, stride, hitSize};
    P.callRegion = {0, 0, 0};
    return pipelines[program] = P;
  }
};

namespace {

// The process's device: created by the first Runner or DeviceHold, shared by those
// created while one lives, destroyed with the last. lavapipe compiles a ray-tracing
// pipeline in seconds (docs/vulkan.md): a test of dozens of small scenes pays it once.
std::shared_ptr<Device> sharedDevice() {
  static std::mutex mutex;
  static std::weak_ptr<Device> current;
  const std::lock_guard lock(mutex);
  if (std::shared_ptr<Device> d = current.lock()) return d;
  auto d = std::make_shared<Device>();
  current = d;
  return d;
}

}  // namespace

// One scene on the shared device: its buffers, acceleration structures and descriptor
// set, freed with its Runner.
struct SceneOnDevice {
  std::shared_ptr<Device> dev;
  std::vector<Buffer> buffers;
  std::vector<VkAccelerationStructureKHR> structures;
  VkAccelerationStructureKHR tlas = VK_NULL_HANDLE;
  Buffer data[OBLONG_BIND_COUNT];  // by binding (0 unused: the TLAS)
  std::vector<Buffer> texelChunks, rmipChunks;  // OBLONG_BIND_TEXELS, OBLONG_BIND_RMIP_DATA
  size_t rayCapacity = 0;
  VkDescriptorPool descPool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  const Pipeline* pipe = nullptr;

  explicit SceneOnDevice(std::shared_ptr<Device> d) : dev(std::move(d)) {
    const VkDevice device = dev->device;
    const VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 1},
                                           {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, OBLONG_BIND_COUNT - 1 + 2 * (OBLONG_CHUNKS - 1)}};
    VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    dpci.maxSets = 1;
    dpci.poolSizeCount = 2;
    dpci.pPoolSizes = sizes;
    check(vkCreateDescriptorPool(device, &dpci, nullptr, &descPool), "vkCreateDescriptorPool");
    VkDescriptorSetAllocateInfo dai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    dai.descriptorPool = descPool;
    dai.descriptorSetCount = 1;
    dai.pSetLayouts = &dev->setLayout;
    if (const VkResult r = vkAllocateDescriptorSets(device, &dai, &set); r != VK_SUCCESS) {
      vkDestroyDescriptorPool(device, descPool, nullptr);  // a throwing constructor runs no destructor
      check(r, "vkAllocateDescriptorSets");
    }
  }
  ~SceneOnDevice() {
    const VkDevice device = dev->device;
    const std::lock_guard lock(dev->mutex);
    vkQueueWaitIdle(dev->queue);
    for (VkAccelerationStructureKHR a : structures) dev->destroyAS(device, a, nullptr);
    dev->freeBuffers(buffers);
    if (descPool) vkDestroyDescriptorPool(device, descPool, nullptr);
  }
  SceneOnDevice(const SceneOnDevice&) = delete;
  SceneOnDevice& operator=(const SceneOnDevice&) = delete;

  Buffer makeBuffer(VkDeviceSize size, VkBufferUsageFlags usage, bool host, bool readback = false) {
    return dev->makeBuffer(buffers, size, usage, host, readback);
  }
  template <typename T>
  Buffer upload(const std::vector<T>& v, VkBufferUsageFlags usage) {
    Buffer b = makeBuffer(v.size() * sizeof(T), usage, true);
    if (!v.empty()) std::memcpy(b.map, v.data(), v.size() * sizeof(T));
    return b;
  }
  // v in buffers of `chunk` elements (at least one buffer, even for an empty v).
  template <typename T>
  std::vector<Buffer> uploadChunks(const std::vector<T>& v, size_t chunk, VkBufferUsageFlags usage) {
    std::vector<Buffer> out;
    for (size_t at = 0; at < v.size() || out.empty(); at += chunk) {
      const size_t n = std::min(chunk, v.size() - std::min(at, v.size()));
      Buffer b = makeBuffer(n * sizeof(T), usage, true);
      if (n) std::memcpy(b.map, v.data() + at, n * sizeof(T));
      out.push_back(b);
    }
    return out;
  }

  // Builds one acceleration structure from one geometry; returns it and its bytes.
  VkAccelerationStructureKHR buildAS(VkAccelerationStructureTypeKHR type, const VkAccelerationStructureGeometryKHR& geom,
                                     uint32_t count, size_t& bytes) {
    VkAccelerationStructureBuildGeometryInfoKHR bi{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR};
    bi.type = type;
    bi.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR;
    bi.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
    bi.geometryCount = 1;
    bi.pGeometries = &geom;
    VkAccelerationStructureBuildSizesInfoKHR sizes{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
    dev->buildSizes(dev->device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &bi, &count, &sizes);
    const Buffer store =
        makeBuffer(sizes.accelerationStructureSize, VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR, false);
    bytes = sizes.accelerationStructureSize;
    VkAccelerationStructureCreateInfoKHR ci{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR};
    ci.buffer = store.buf;
    ci.size = sizes.accelerationStructureSize;
    ci.type = type;
    VkAccelerationStructureKHR as;
    check(dev->createAS(dev->device, &ci, nullptr, &as), "vkCreateAccelerationStructureKHR");
    structures.push_back(as);
    const VkDeviceSize align = std::max<VkDeviceSize>(dev->asProps.minAccelerationStructureScratchOffsetAlignment, 1);
    const Buffer scratch = makeBuffer(sizes.buildScratchSize + align, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, false);
    bi.dstAccelerationStructure = as;
    bi.scratchData.deviceAddress = alignUp(scratch.addr, align);
    VkAccelerationStructureBuildRangeInfoKHR range{count, 0, 0, 0};
    const VkAccelerationStructureBuildRangeInfoKHR* ranges = &range;
    dev->submit([&](VkCommandBuffer cb) {
      // Earlier builds (the bottom levels a top level reads) complete first.
      VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
      mb.srcAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR;
      mb.dstAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR;
      vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                           VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR, 0, 1, &mb, 0, nullptr, 0, nullptr);
      dev->cmdBuildAS(cb, 1, &bi, &ranges);
    });
    return as;
  }

  void writeDescriptors() {
    VkWriteDescriptorSetAccelerationStructureKHR asw{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR};
    asw.accelerationStructureCount = 1;
    asw.pAccelerationStructures = &tlas;
    std::vector<VkWriteDescriptorSet> w(OBLONG_BIND_COUNT);
    std::vector<VkDescriptorBufferInfo> infos(OBLONG_BIND_COUNT);
    // Chunked bindings: every slot past the last chunk repeats chunk 0 (never read).
    std::vector<VkDescriptorBufferInfo> texelInfos(OBLONG_CHUNKS), rmipInfos(OBLONG_CHUNKS);
    for (uint32_t k = 0; k < OBLONG_CHUNKS; ++k) {
      texelInfos[k] = {texelChunks[k < texelChunks.size() ? k : 0].buf, 0, VK_WHOLE_SIZE};
      rmipInfos[k] = {rmipChunks[k < rmipChunks.size() ? k : 0].buf, 0, VK_WHOLE_SIZE};
    }
    for (uint32_t b = 0; b < OBLONG_BIND_COUNT; ++b) {
      w[b] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      w[b].dstSet = set;
      w[b].dstBinding = b;
      w[b].descriptorCount = 1;
      if (b == OBLONG_BIND_TLAS) {
        w[b].pNext = &asw;
        w[b].descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
      } else if (b == OBLONG_BIND_TEXELS || b == OBLONG_BIND_RMIP_DATA) {
        w[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        w[b].descriptorCount = OBLONG_CHUNKS;
        w[b].pBufferInfo = b == OBLONG_BIND_TEXELS ? texelInfos.data() : rmipInfos.data();
      } else {
        infos[b] = {data[b].buf, 0, VK_WHOLE_SIZE};
        w[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        w[b].pBufferInfo = &infos[b];
      }
    }
    vkUpdateDescriptorSets(dev->device, uint32_t(w.size()), w.data(), 0, nullptr);
  }
};


Runner::Runner(GpuRecords R) : geometryName_(R.geometryName), baseTriangles_(R.baseTriangles) {
  const size_t nMeshes = R.meshes.size();
  if (R.meshTriangles.size() != nMeshes || R.meshVertices.size() != nMeshes || R.aabbs.size() != R.tris.size())
    fail("--device vulkan", "internal: inconsistent records ({} meshes, {} / {} sizes, {} prisms, {} boxes)", nMeshes,
         R.meshTriangles.size(), R.meshVertices.size(), R.tris.size(), R.aabbs.size());
  scene_ = std::make_unique<SceneOnDevice>(sharedDevice());
  SceneOnDevice& S = *scene_;
  Device& D = *S.dev;
  std::unique_lock lock(D.mutex);
  VkDeviceSize maxRange = D.props.limits.maxStorageBufferRange;
  // OBLONG_VULKAN_MAX_BUFFER (bytes) lowers the range, to test the chunked layout with
  // small maps.
  if (const char* e = std::getenv("OBLONG_VULKAN_MAX_BUFFER")) {
    char* end = nullptr;
    const unsigned long long v = std::strtoull(e, &end, 10);
    if (!end || *end || v < 64) fail("OBLONG_VULKAN_MAX_BUFFER", "expected bytes (at least 64), got '{}'", e);
    maxRange = std::min<VkDeviceSize>(maxRange, v);
  }
  auto fits = [&](size_t bytes, const char* what) {
    if (bytes > maxRange)
      fail("--device vulkan", "{}: {} bytes of {} exceed maxStorageBufferRange ({} bytes)", D.props.deviceName, bytes,
           what, maxRange);
  };
  fits(R.tris.size() * sizeof(TriGpu), "displaced triangles");
  // Texels and RMIP words: chunks of the largest power of two of 4-byte elements that
  // fits the range (at most 2^30), up to OBLONG_CHUNKS of them.
  const int chunkShift = std::min(30, int(std::bit_width(uint64_t(maxRange / 4))) - 1);
  const size_t chunk = size_t(1) << chunkShift;
  for (auto [n, what] : {std::pair{R.texels.size(), "height maps"}, std::pair{R.rmipData.size(), "RMIP layers"}})
    if ((n + chunk - 1) / chunk > OBLONG_CHUNKS)
      fail("--device vulkan", "{}: {} bytes of {} need {} buffers of {} bytes (maxStorageBufferRange), more than the "
           "{} the shaders bind; use a smaller map, or rmip's \"resolution\" for the layers",
           D.props.deviceName, n * 4, what, (n + chunk - 1) / chunk, chunk * 4, OBLONG_CHUNKS);
  for (MeshGpu& m : R.meshes) m.chunkShift = chunkShift;
  const VkBufferUsageFlags ssbo = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  const VkBufferUsageFlags asInput = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR;
  S.data[OBLONG_BIND_TRIANGLES] = S.upload(R.tris, ssbo);
  S.data[OBLONG_BIND_MESHES] = S.upload(R.meshes, ssbo);
  S.texelChunks = S.uploadChunks(R.texels, chunk, ssbo);
  S.rmipChunks = S.uploadChunks(R.rmipData, chunk, ssbo);
  std::vector<float>().swap(R.texels);  // the device has them now
  std::vector<uint32_t>().swap(R.rmipData);
  S.data[OBLONG_BIND_RMIP_LAYERS] = S.upload(R.rmipLayers, ssbo);
  S.data[OBLONG_BIND_PLAIN_INDEX] = S.upload(R.plainIndex, ssbo | asInput);
  S.data[OBLONG_BIND_PLAIN_UV] = S.upload(R.plainUV, ssbo);
  S.data[OBLONG_BIND_PLAIN_POS] = S.upload(R.plainPos, ssbo | asInput);
  const Buffer aabbBuf = S.upload(R.aabbs, asInput);

  // Bottom levels: one per mesh (AABBs per prism, or triangles), then the top level.
  size_t blasBytes = 0;
  std::vector<VkAccelerationStructureInstanceKHR> instances;
  for (size_t mi = 0; mi < nMeshes; ++mi) {
    const MeshGpu& m = R.meshes[mi];
    const uint32_t count = R.meshTriangles[mi];
    if (count == 0) continue;
    VkAccelerationStructureGeometryKHR g{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR};
    g.flags = VK_GEOMETRY_OPAQUE_BIT_KHR;
    if (m.displaced) {
      g.geometryType = VK_GEOMETRY_TYPE_AABBS_KHR;
      g.geometry.aabbs = {VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_AABBS_DATA_KHR};
      g.geometry.aabbs.data.deviceAddress = aabbBuf.addr + VkDeviceSize(m.triOffset) * sizeof(VkAabbPositionsKHR);
      g.geometry.aabbs.stride = sizeof(VkAabbPositionsKHR);
    } else {
      g.geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR;
      auto& t = g.geometry.triangles;
      t = {VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR};
      t.vertexFormat = VK_FORMAT_R32G32B32_SFLOAT;
      t.vertexData.deviceAddress = S.data[OBLONG_BIND_PLAIN_POS].addr + VkDeviceSize(m.vertexOffset) * 12;
      t.vertexStride = 12;
      t.maxVertex = std::max<uint32_t>(R.meshVertices[mi], 1) - 1;
      t.indexType = VK_INDEX_TYPE_UINT32;
      t.indexData.deviceAddress = S.data[OBLONG_BIND_PLAIN_INDEX].addr + VkDeviceSize(m.indexOffset) * 4;
    }
    size_t bytes = 0;
    const VkAccelerationStructureKHR blas = S.buildAS(VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, g, count, bytes);
    blasBytes += bytes;
    VkAccelerationStructureInstanceKHR inst{};
    // The identity: prisms' boxes and plain triangles are in the world; the intersection
    // shader moves the ray into the mesh's frame (MeshGpu::origin).
    inst.transform.matrix[0][0] = inst.transform.matrix[1][1] = inst.transform.matrix[2][2] = 1.0f;
    inst.instanceCustomIndex = uint32_t(mi);
    inst.mask = 0xFF;
    inst.instanceShaderBindingTableRecordOffset = m.displaced ? OBLONG_HITGROUP_PRISM : OBLONG_HITGROUP_TRIANGLES;
    inst.flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR;
    inst.accelerationStructureReference = D.address(blas);
    instances.push_back(inst);
  }
  const Buffer instBuf = S.upload(instances, asInput);
  VkAccelerationStructureGeometryKHR tg{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR};
  tg.geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR;
  tg.geometry.instances = {VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR};
  tg.geometry.instances.data.deviceAddress = instBuf.addr;
  size_t tlasBytes = 0;
  S.tlas = S.buildAS(VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, tg, uint32_t(instances.size()), tlasBytes);

  // The displaced meshes' traversal (one per scene: the configuration is the scene's).
  int method = OBLONG_METHOD_CANONICAL;
  bool any = false;
  for (const MeshGpu& m : R.meshes) {
    if (!m.displaced) continue;
    if (any && m.method != method) fail("--device vulkan", "the scene's meshes ask for two traversals ({} and {})", method, m.method);
    method = m.method, any = true;
  }
  size_t program = kProgramCount;
  for (size_t i = 0; i < kProgramCount; ++i)
    if (kPrograms[i].method == method) program = i;
  if (program == kProgramCount) fail("--device vulkan", "no intersection shader for traversal {} (a newer bake file?)", method);
  S.pipe = &D.pipeline(program);
  memory_ = {{"vulkan/triangles", R.triBytes},
             {kPrograms[program].pyramid, R.rmipBytes},
             {"vulkan/height_maps", R.texelBytes},
             {"vulkan/aabbs", R.aabbs.size() * sizeof(VkAabbPositionsKHR)},
             {"vulkan/plain_meshes", R.plainIndex.size() * 4 + R.plainUV.size() * 8 + R.plainPos.size() * 4},
             {"vulkan/blas", blasBytes},
             {"vulkan/tlas", tlasBytes}};
  // lavapipe compiles the pipeline at its first dispatch (tens of seconds for the
  // intersection shader unless Mesa's shader cache has it): one ray here, so that the
  // compilation counts as build time, not as tracing time.
  lock.unlock();
  RayGpu warm{vec3(0.0f), vec3(0.0f, 0.0f, 1.0f), 0.0f, 0.0f};
  HitGpu hit;
  trace(&warm, 1, &hit, nullptr, false);
}

Runner::~Runner() = default;

DeviceHold::DeviceHold() : device_(sharedDevice()) {}
DeviceHold::~DeviceHold() = default;

namespace {

// NAME.spv from dir as 32-bit words, or one error line naming the file.
std::vector<uint32_t> readSpirv(const std::string& dir, const std::string& name) {
  const std::string path = dir + "/" + name + ".spv";
  std::ifstream f(path, std::ios::binary);
  if (!f) fail(path, "cannot open the SPIR-V module");
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) fail(path, "read failed");
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), words.size() * 4);
  if (bytes.size() < 20 || bytes.size() % 4 != 0 || words[0] != 0x07230203u)
    fail(path, "not a SPIR-V module ({} bytes{})", bytes.size(),
         bytes.size() >= 4 && words[0] != 0x07230203u ? ", no SPIR-V magic number" : "");
  return words;
}

// The shader stages of VkShaderStageFlags, by name.
std::string stageNames(uint32_t stages) {
  const std::pair<uint32_t, const char*> names[] = {
      {VK_SHADER_STAGE_RAYGEN_BIT_KHR, "raygen"},       {VK_SHADER_STAGE_MISS_BIT_KHR, "miss"},
      {VK_SHADER_STAGE_INTERSECTION_BIT_KHR, "intersection"}, {VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR, "closest hit"},
      {VK_SHADER_STAGE_ANY_HIT_BIT_KHR, "any hit"},      {VK_SHADER_STAGE_CALLABLE_BIT_KHR, "callable"},
      {VK_SHADER_STAGE_COMPUTE_BIT, "compute"}};
  std::string out;
  for (const auto& [bit, name] : names)
    if (stages & bit) {
      if (!out.empty()) out += '+';
      out += name;
    }
  return out.empty() ? fmt::format("0x{:x}", stages) : out;
}

double statisticValue(const VkPipelineExecutableStatisticKHR& s) {
  switch (s.format) {
    case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR: return s.value.b32 ? 1.0 : 0.0;
    case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR: return double(s.value.i64);
    case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR: return double(s.value.u64);
    case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_FLOAT64_KHR: return s.value.f64;
    default: return 0.0;
  }
}

}  // namespace

PipelineStatistics pipelineStatistics(const std::string& spirvDir) {
  Device D(true);
  PipelineStatistics out;
  out.device = D.props.deviceName;
  out.driver = D.driverInfo;
  out.supported = D.executableInfo;
  std::vector<uint32_t> files[5];
  if (!spirvDir.empty())
    for (int i = 0; i < 5; ++i)
      if (kStageFiles[i]) files[i] = readSpirv(spirvDir, kStageFiles[i]);
  const StageCode built[5] = {{kRgen, sizeof kRgen}, {kMiss, sizeof kMiss}, {nullptr, 0},
                              {kPrismHit, sizeof kPrismHit}, {kTriangleHit, sizeof kTriangleHit}};
  for (const IntersectionProgram& prog : kPrograms) {
    StageCode code[5];
    std::vector<uint32_t> own;
    if (!spirvDir.empty()) own = readSpirv(spirvDir, prog.stage);
    for (int i = 0; i < 5; ++i) {
      const std::vector<uint32_t>& w = i == 2 ? own : files[i];
      code[i] = spirvDir.empty() ? (i == 2 ? StageCode{prog.code, prog.bytes} : built[i])
                                 : StageCode{w.data(), w.size() * sizeof(uint32_t)};
    }
    const VkPipeline pipe =
        D.createPipeline(code, D.executableInfo ? VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR : 0);
    PipelineProgram P;
    P.method = prog.name;
    P.stage = prog.stage;
    if (D.executableInfo) {
      VkPipelineInfoKHR pi{VK_STRUCTURE_TYPE_PIPELINE_INFO_KHR};
      pi.pipeline = pipe;
      uint32_t ne = 0;
      check(D.executableProps(D.device, &pi, &ne, nullptr), "vkGetPipelineExecutablePropertiesKHR");
      std::vector<VkPipelineExecutablePropertiesKHR> exe(ne, {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_PROPERTIES_KHR});
      check(D.executableProps(D.device, &pi, &ne, exe.data()), "vkGetPipelineExecutablePropertiesKHR");
      for (uint32_t e = 0; e < ne; ++e) {
        PipelineExecutable X{exe[e].name, exe[e].description, stageNames(exe[e].stages), exe[e].subgroupSize, {}};
        VkPipelineExecutableInfoKHR ei{VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR};
        ei.pipeline = pipe;
        ei.executableIndex = e;
        uint32_t ns = 0;
        check(D.executableStats(D.device, &ei, &ns, nullptr), "vkGetPipelineExecutableStatisticsKHR");
        std::vector<VkPipelineExecutableStatisticKHR> st(ns, {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR});
        check(D.executableStats(D.device, &ei, &ns, st.data()), "vkGetPipelineExecutableStatisticsKHR");
        for (const VkPipelineExecutableStatisticKHR& s : st)
          X.statistics.push_back({s.name, s.description, statisticValue(s)});
        P.executables.push_back(std::move(X));
      }
    }
    vkDestroyPipeline(D.device, pipe, nullptr);
    out.programs.push_back(std::move(P));
  }
  return out;
}

std::string Runner::deviceName() const { return scene_->dev->props.deviceName; }
std::string Runner::driverInfo() const { return scene_->dev->driverInfo; }

void Runner::trace(const RayGpu* rays, size_t n, HitGpu* hits, CountersGpu* counters, bool anyHit, double* seconds,
                   double* gpuSeconds) {
  SceneOnDevice& S = *scene_;
  Device& D = *S.dev;
  for (size_t i = 0; i < n; ++i)
    if (!(rays[i].tmin >= 0.0f))
      fail("--device vulkan", "ray {}: tmin = {} < 0 (Vulkan needs tmin >= 0)", i, rays[i].tmin);
  const std::lock_guard lock(D.mutex);
  // Batches of at most 2^20 rays (32 MiB per buffer, within any storage buffer range).
  const size_t batch = std::min<size_t>({size_t(1) << 20, D.props.limits.maxStorageBufferRange / sizeof(HitGpu),
                                         D.rt.maxRayDispatchInvocationCount});
  if (S.rayCapacity == 0 || std::min(n, batch) > S.rayCapacity) {  // grow (old buffers are freed with the scene)
    const size_t cap = std::max<size_t>(std::min(n, batch), 1);
    S.data[OBLONG_BIND_RAYS] = S.makeBuffer(cap * sizeof(RayGpu), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true);
    S.data[OBLONG_BIND_HITS] = S.makeBuffer(cap * sizeof(HitGpu), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, true);
    S.data[OBLONG_BIND_COUNTERS] = S.makeBuffer(cap * sizeof(CountersGpu), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, true);
    S.rayCapacity = cap;
    S.writeDescriptors();
  }
  double total = 0, gpu = 0;
  const double tickSeconds = double(D.props.limits.timestampPeriod) * 1e-9;
  const uint64_t tickMask = D.timestampBits >= 64 ? ~uint64_t(0) : (uint64_t(1) << D.timestampBits) - 1;
  for (size_t off = 0; off < n; off += S.rayCapacity) {
    const size_t m = std::min(S.rayCapacity, n - off);
    std::memcpy(S.data[OBLONG_BIND_RAYS].map, rays + off, m * sizeof(RayGpu));
    std::memset(S.data[OBLONG_BIND_COUNTERS].map, 0, m * sizeof(CountersGpu));
    const PushGpu push{0u, uint32_t(m), anyHit ? 1u : 0u, 0u};
    const auto start = std::chrono::steady_clock::now();
    D.submit([&](VkCommandBuffer cb) {
      if (D.timestamps) {
        vkCmdResetQueryPool(cb, D.timestamps, 0, 2);
        vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, D.timestamps, 0);
      }
      vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, S.pipe->pipeline);
      vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, D.pipeLayout, 0, 1, &S.set, 0, nullptr);
      vkCmdPushConstants(cb, D.pipeLayout,
                         VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR |
                             VK_SHADER_STAGE_INTERSECTION_BIT_KHR | VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR,
                         0, sizeof push, &push);
      const Pipeline& P = *S.pipe;
      D.cmdTraceRays(cb, &P.rgenRegion, &P.missRegion, &P.hitRegion, &P.callRegion, push.rayCount, 1, 1);
      if (D.timestamps) vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, D.timestamps, 1);
    });
    total += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (D.timestamps) {
      uint64_t ticks[2] = {0, 0};
      check(vkGetQueryPoolResults(D.device, D.timestamps, 0, 2, sizeof ticks, ticks, sizeof(uint64_t),
                                  VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
            "vkGetQueryPoolResults");
      gpu += double((ticks[1] - ticks[0]) & tickMask) * tickSeconds;
    }
    std::memcpy(hits + off, S.data[OBLONG_BIND_HITS].map, m * sizeof(HitGpu));
    if (counters) std::memcpy(counters + off, S.data[OBLONG_BIND_COUNTERS].map, m * sizeof(CountersGpu));
  }
  if (seconds) *seconds = total;
  if (gpuSeconds) *gpuSeconds = D.timestamps ? gpu : -1.0;
}

}  // namespace oblong::vk
