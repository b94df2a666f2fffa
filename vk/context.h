// Headless Vulkan: instance/device selection (discrete GPU preferred, lavapipe as fallback), buffers,
// compute kernels with push descriptors, command recording, named timestamp queries.
// Every VkResult goes through VK_CHECK and becomes a cs::Error naming the call; never compiled out.
#pragma once
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <span>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <vulkan/vulkan.h>

#include "core/error.h"

namespace cs::vk {

const char* resultName(VkResult r);
[[noreturn]] void fail(VkResult r, const char* call, const char* file, int line);

#define VK_CHECK(call)                                                    \
  do {                                                                    \
    VkResult vk_check_r_ = (call);                                        \
    if (vk_check_r_ != VK_SUCCESS) ::cs::vk::fail(vk_check_r_, #call, __FILE__, __LINE__); \
  } while (0)

// A driver call that can crash inside the driver when the process runs out of memory (lavapipe's device
// creation and its shader compiler dereference failed allocations): while one is alive, a SIGSEGV,
// SIGBUS, SIGILL or SIGFPE prints "<program>: error: the Vulkan driver crashed in <call> (...)", runs the
// cleanup set below and exits 1. Anywhere else such a signal keeps its default action, so a bug of ours
// stays a crash. The guarded calls: createContext, vkAllocateMemory, pipeline creation.
class DriverCall {
 public:
  explicit DriverCall(const char* call);
  ~DriverCall();
  DriverCall(const DriverCall&) = delete;
  DriverCall& operator=(const DriverCall&) = delete;

 private:
  const char* previous_;
};
// What a driver crash runs before exiting (the CLI removes its unfinished output folders); best effort.
void setDriverCrashCleanup(void (*cleanup)());

// Whether the physical device offers the extension.
bool hasDeviceExtension(VkPhysicalDevice device, const char* name);
// How createContext ranks device types when it chooses one: discrete 4, integrated 3, virtual 2, cpu 1.
int deviceTypeRank(VkPhysicalDeviceType type);

struct ContextOptions {
  std::string device;         // "" = automatic (discrete > integrated > virtual > cpu); else index or name substring
  bool validation = false;    // enable VK_LAYER_KHRONOS_validation and count its messages
  bool quiet = false;         // do not print the chosen device
};

// What a frame costs the host, counted by vk/ since the context was made; a method reports the
// difference over its frame (method/method.h: the keys submits_per_frame, host_syncs_per_frame,
// readback_bytes_per_frame, allocations_per_frame, dispatches_per_frame).
struct HostCost {
  uint64_t submits = 0;        // queue submissions (Commands::submit)
  uint64_t hostSyncs = 0;      // host waits for the device (fence waits)
  uint64_t readbackBytes = 0;  // bytes copied from device buffers into host memory (download, readBack)
  uint64_t allocations = 0;    // device memory allocations (buffers, images, staging)
  uint64_t dispatches = 0;     // compute dispatches, direct and indirect, and draw calls
};
HostCost operator-(const HostCost& a, const HostCost& b);

struct Buffer;

struct Context {
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queueFamily = 0;
  VkCommandPool commandPool = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties properties{};
  VkPhysicalDeviceMemoryProperties memory{};
  uint32_t subgroupSize = 0;
  bool hostVisibleDeviceLocal = false;   // unified memory (lavapipe, some iGPUs): no staging needed
  bool geometryShader = false;           // the device's geometryShader feature, enabled when it has it (RTW)
  bool robustBufferAccess = false;       // enabled when the device offers it: an out-of-bounds access reads 0 or is
                                         // dropped instead of touching other memory (a kernel bug cannot corrupt
                                         // another buffer on a GPU; lavapipe bounds-checks either way)
  PFN_vkCmdPushDescriptorSetKHR cmdPushDescriptorSet = nullptr;

  // A device adopted from the caller (adoptDevice): the context destroys only what it made, never waits
  // for the device, and never submits (Commands record into the caller's command buffer). Uploads into
  // memory the host cannot map are staged and queued in pendingUploads for the next recorded frame.
  bool adopted = false;
  // A device shared with the caller (shareDevice): the context submits to the caller's queue with its own
  // command pool and fence, and destroys only those.
  bool ownsDevice = true;
  struct PendingUpload {
    std::unique_ptr<Buffer> staging;
    VkBuffer dst = VK_NULL_HANDLE;
    VkDeviceSize offset = 0, bytes = 0;
  };
  std::vector<PendingUpload> pendingUploads;

  HostCost cost;                    // see HostCost
  std::unique_ptr<Buffer> staging;  // discrete GPUs: the one staging buffer upload/download reuse (grown as needed)

  // validation messages (warnings and errors) seen so far; tests fail when this grows
  uint64_t validationMessages = 0;
  std::string lastValidationMessage;
  std::function<void(const std::string&)> onValidationMessage;  // tests turn messages into failures

  Context() = default;
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  ~Context();

  std::string deviceName() const { return properties.deviceName; }
  std::string deviceTypeName() const;
  std::string driverDescription() const;  // "llvmpipe (LLVM ...) / Mesa ... / Vulkan 1.3.230"
  VkDeviceSize maxStorageBufferRange() const { return properties.limits.maxStorageBufferRange; }
  uint32_t maxWorkgroups() const { return properties.limits.maxComputeWorkGroupCount[0]; }
  double timestampPeriodNs() const { return properties.limits.timestampPeriod; }
  // Whether timestamps written inside one submission time the commands between them. Not on a CPU
  // device: lavapipe runs draws and dispatches on worker threads behind the command stream, and a stage's
  // timestamps there were measured holding another stage's work (a 48-byte fill "taking" 50 ms); methods
  // time whole submissions by the wall clock instead.
  bool timestampsTrusted() const {
    return properties.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU && properties.limits.timestampPeriod > 0;
  }
};

std::unique_ptr<Context> createContext(const ContextOptions& options);

// The caller's Vulkan objects, adopted by a context that then records into the caller's command buffers
// and owns nothing of the caller's. The device must have been created with what deviceRequirements() lists.
struct AdoptedDevice {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  uint32_t queueFamily = 0;  // the family whose command buffers the frames are recorded into (compute)
  PFN_vkGetInstanceProcAddr getInstanceProcAddr = nullptr;
};
// What a device needs for the cone path: the extensions and the features to enable at vkCreateDevice.
struct DeviceRequirements {
  uint32_t apiVersion = VK_API_VERSION_1_2;
  std::vector<const char*> extensions;
  // Vulkan 1.0 and 1.2 features that must be VK_TRUE
  bool shaderInt64 = true, shaderBufferInt64Atomics = true;
};
DeviceRequirements deviceRequirements();
// cs::Error naming what the device lacks (an extension, a feature, subgroup operations, a queue family
// without compute) -- checked before anything is made.
std::unique_ptr<Context> adoptDevice(const AdoptedDevice& device);
// The caller's device and one of its queues (of d.queueFamily), for work that submits and waits as a
// context of its own does -- the registry's methods beside a renderer's frames (viewer/). The context makes
// its own command pool and fence; submissions to `queue` must come from one thread at a time, the
// caller's included. Checked as adoptDevice checks; the caller sets geometryShader and robustBufferAccess
// when it enabled them.
std::unique_ptr<Context> shareDevice(const AdoptedDevice& d, VkQueue queue);
// Records the copies of ctx.pendingUploads into `cmd` (then a barrier) and returns their staging buffers,
// which the caller keeps until the command buffer has executed.
class Commands;
std::vector<std::unique_ptr<Buffer>> recordPendingUploads(Context& ctx, Commands& cmd);
// One line per physical device, for --device listing.
std::vector<std::string> listDevices();

enum class Memory { Device, HostVisible };

// A buffer with its own memory. Move-only; destroyed with its context still alive.
struct Buffer {
  Context* ctx = nullptr;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // non-null when host visible
  // Views of the whole buffer as a uniform texel buffer, one per format, made on first use (texels())
  // and destroyed with the buffer.
  mutable std::vector<std::pair<VkFormat, VkBufferView>> views;  // a cache: texels() fills it on a const buffer

  Buffer() = default;
  Buffer(Buffer&& o) noexcept { *this = std::move(o); }
  Buffer& operator=(Buffer&& o) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  ~Buffer() { reset(); }
  void reset();
  explicit operator bool() const { return buffer != VK_NULL_HANDLE; }
};


// Storage, uniform texel + transfer usage are always added. Size 0 is rounded up to 16 bytes.
// Throws cs::Error if size exceeds what the device can allocate.
Buffer createBuffer(Context& ctx, VkDeviceSize size, Memory memory = Memory::Device,
                    VkBufferUsageFlags extraUsage = 0);
// Host <-> buffer copies; through the context's staging buffer (one submit and wait each) when the buffer
// is not host visible. Downloads count their bytes in ctx.cost.readbackBytes.
void upload(Context& ctx, Buffer& dst, const void* data, VkDeviceSize bytes, VkDeviceSize offset = 0);
void download(Context& ctx, const Buffer& src, void* data, VkDeviceSize bytes, VkDeviceSize offset = 0);
// An upload written in place: fill(p) writes the `bytes` at p, which is dst's own mapping (at `offset`)
// where dst is host visible, else the context's staging buffer, then copied (one submit and wait). No
// host copy of the data: the caller's fill is the only writer. fill must only write p, never read it
// (staging memory may be uncached).
void uploadInPlace(Context& ctx, Buffer& dst, VkDeviceSize bytes, VkDeviceSize offset,
                   const std::function<void(void*)>& fill);
template <class T>
std::vector<T> download(Context& ctx, const Buffer& src, size_t count, size_t first = 0) {
  std::vector<T> v(count);
  if (count) download(ctx, src, v.data(), count * sizeof(T), first * sizeof(T));
  return v;
}

// A host-visible copy of device results, filled inside a frame's own command buffer so that reading them
// needs no submit of its own: on unified memory (hostVisibleDeviceLocal) the source buffers are read
// directly and nothing is recorded; elsewhere record() adds a copy into `host`, which grows between
// frames only. After the frame's submit, read() copies the bytes out (counted as readback).
class Commands;
class Readback {
 public:
  explicit Readback(Context& ctx) : ctx_(ctx) {}
  // Plans `bytes` of `src` from `srcOffset`; returns a slot for read(). Call before record().
  uint32_t add(const Buffer& src, VkDeviceSize bytes, VkDeviceSize srcOffset = 0);
  // Records the copies of every planned slot (no-op on unified memory); allocates only when it grows.
  void record(Commands& cmd);
  // Copies a slot into `dst`; a slot larger than `dst` is an error, never a write past it.
  template <class T>
  void read(uint32_t slot, std::span<T> dst) const {
    readBytes(slot, dst.data(), dst.size_bytes());
  }
  template <class T>
  void read(uint32_t slot, std::vector<T>& dst) const {
    readBytes(slot, dst.data(), dst.size() * sizeof(T));
  }
  template <class T, size_t N>
  void read(uint32_t slot, T (&dst)[N]) const {
    readBytes(slot, dst, sizeof(dst));
  }
  void clear() { slots_.clear(); }
  uint64_t bytesAllocated() const;

 private:
  struct Slot {
    const Buffer* src;
    VkDeviceSize bytes, srcOffset, hostOffset;
  };
  Context& ctx_;
  std::vector<Slot> slots_;
  std::unique_ptr<Buffer> host_;
  void readBytes(uint32_t slot, void* data, size_t capacity) const;
};

// A 2-D render target with its own device-local memory and one view. Move-only.
struct Image {
  Context* ctx = nullptr;
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkDeviceSize bytes = 0;  // memory allocated

  Image() = default;
  Image(Image&& o) noexcept { *this = std::move(o); }
  Image& operator=(Image&& o) noexcept;
  Image(const Image&) = delete;
  Image& operator=(const Image&) = delete;
  ~Image() { reset(); }
  void reset();
};

// Optimal tiling, one mip, one layer. `hint` is added to the error when the memory cannot be had.
Image createImage(Context& ctx, uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage,
                  VkImageAspectFlags aspect, const std::string& hint = "lower the resolution");
// A shader module from SPIR-V words (the caller destroys it).
VkShaderModule createShaderModule(Context& ctx, const uint32_t* spirv, size_t spirvBytes);

// The fixed-function state every triangle pass here shares: triangle lists of vec3 vertex streams
// (stream i at binding i, location i), no culling (two-sided), one sample, depth test and write, dynamic
// viewport and scissor. What differs between passes is below.
struct TrianglePipelineDesc {
  VkShaderModule vert = VK_NULL_HANDLE, frag = VK_NULL_HANDLE;
  VkShaderModule geom = VK_NULL_HANDLE;       // optional geometry stage (the device's geometryShader feature)
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkRenderPass renderPass = VK_NULL_HANDLE;
  uint32_t vertexStreams = 1;                 // at most 4 (0: the vertex stage makes its own positions)
  uint32_t colorAttachments = 1;              // at most 4
  VkColorComponentFlags colorWriteMask = 0xF;
  VkCompareOp depthCompare = VK_COMPARE_OP_LESS;
  bool depth = true;                          // false: the pass has no depth attachment (no depth state)
};
VkPipeline createTrianglePipeline(Context& ctx, const TrianglePipelineDesc& desc);

// A range of a buffer bound to one storage-buffer binding. Range VK_WHOLE_SIZE = rest of the buffer.
struct BufferRange {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceSize offset = 0;
  VkDeviceSize range = VK_WHOLE_SIZE;
  VkDeviceSize bufferSize = 0;  // the whole buffer's bytes when known (a VK_WHOLE_SIZE range is checked by it)
  VkBufferView view = VK_NULL_HANDLE;  // set for a uniform texel buffer binding (texels())
  bool uniform = false;                // a uniform buffer binding (uniforms())
  BufferRange() = default;
  BufferRange(const Buffer& b) : buffer(b.buffer), bufferSize(b.size) {}  // NOLINT: implicit on purpose
  BufferRange(const Buffer& b, VkDeviceSize off, VkDeviceSize len)
      : buffer(b.buffer), offset(off), range(len), bufferSize(b.size) {}
};

// The whole buffer as a uniform texel buffer of `format` texels, for a kernel binding declared as one
// (`uniform samplerBuffer`): on lavapipe texel fetches of 16-byte texels gather several times faster
// than storage-buffer loads (docs/ARCHITECTURE.md, "Memory access"), on GPUs they read through the texture cache. The view is made
// on first use and kept with the buffer; cs::Error when the buffer holds more texels than the device's
// maxTexelBufferElements. Formats: RGBA32F, RGBA32UI, and R32UI for uint arrays read one word a fetch
// (all three are uniform texel buffer formats every Vulkan device supports).
BufferRange texels(const Buffer& buffer, VkFormat format);

// The first `bytes` of the buffer as a uniform buffer, for a kernel binding declared as one
// (a `uniform` block): the few words every invocation of a dispatch reads at the same
// place (a tree's shape, the traversal's state). Read at a dynamically uniform offset, lavapipe loads a
// uniform buffer's word once for the SIMD lanes (a texel fetch is a gather a lane, a storage load a loop
// over the lanes); a GPU serves it from its constant cache. cs::Error above maxUniformBufferRange.
BufferRange uniforms(const Buffer& buffer, VkDeviceSize bytes);

// A compute pipeline whose set 0 holds `bindings` buffers (bindings 0..n-1), each of the descriptor type its
// SPIR-V declares -- a storage buffer, a uniform texel buffer (bound with vk::texels()) or a uniform buffer
// (bound with vk::uniforms()) -- pushed with push descriptors, plus `pushBytes` of push constants.
struct Kernel {
  Context* ctx = nullptr;
  std::string name;
  VkShaderModule module = VK_NULL_HANDLE;
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  uint32_t bindings = 0;
  std::vector<VkDescriptorType> types;  // per binding, as the SPIR-V declares it (spirvInterface)
  uint32_t pushBytes = 0;
  uint32_t localSize[3] = {1, 1, 1};  // the workgroup shape the SPIR-V declares (LocalSize)

  Kernel() = default;
  Kernel(Kernel&& o) noexcept { *this = std::move(o); }
  Kernel& operator=(Kernel&& o) noexcept;
  Kernel(const Kernel&) = delete;
  Kernel& operator=(const Kernel&) = delete;
  ~Kernel() { reset(); }
  void reset();
};

struct SpecConstant {
  uint32_t id;
  uint32_t value;
};

// What a compute module's SPIR-V declares: its descriptor bindings (set 0) with the descriptor type of each
// -- from the variable's storage class and type: StorageBuffer (or a Uniform BufferBlock) a storage buffer,
// a Uniform Block a uniform buffer, an image of Dim Buffer a uniform or storage texel buffer (Sampled 1 or
// 2), any other image a sampled or storage image, a sampler, an image with its sampler -- and its workgroup
// shape. An array of descriptors, or one binding declared as two types, is an error.
struct SpirvInterface {
  std::map<uint32_t, VkDescriptorType> bindings;
  uint32_t localSize[3] = {1, 1, 1};
  uint32_t pushBytes = 0;  // the push-constant block's size: its last member's offset plus that member's size
};
SpirvInterface spirvInterface(const uint32_t* spirv, size_t spirvBytes);
const char* descriptorTypeName(VkDescriptorType type);  // "a storage buffer", for messages
// A kernel whose bindings are not exactly 0 .. bindings - 1 in its SPIR-V, whose push-constant block is
// not the size of the struct the host pushes (pushBytes), or that declares a binding Commands cannot push
// (an image, a sampler, a storage texel buffer), is an error naming it.
Kernel createKernel(Context& ctx, const char* name, const uint32_t* spirv, size_t spirvBytes,
                    uint32_t bindings, uint32_t pushBytes, std::initializer_list<SpecConstant> spec = {});
// Convenience for arrays generated by glslangValidator --vn.
template <size_t N>
Kernel createKernel(Context& ctx, const char* name, const uint32_t (&spirv)[N], uint32_t bindings,
                    uint32_t pushBytes, std::initializer_list<SpecConstant> spec = {}) {
  return createKernel(ctx, name, spirv, sizeof(spirv), bindings, pushBytes, spec);
}

// Named GPU timestamps. Mark at stage boundaries inside a command buffer; read after the submit.
struct Timer {
  Context* ctx = nullptr;
  VkQueryPool pool = VK_NULL_HANDLE;
  uint32_t capacity = 0;
  std::vector<std::string> names;  // one per written query
  Timer() = default;
  Timer(Timer&& o) noexcept { *this = std::move(o); }
  Timer& operator=(Timer&& o) noexcept;
  Timer(const Timer&) = delete;
  Timer& operator=(const Timer&) = delete;
  ~Timer() { reset(); }
  void reset();
  void restart();  // forget the marks so the timer can record another frame
  // (name, ms) for each interval between consecutive marks, named by the later mark's name.
  std::vector<std::pair<std::string, double>> intervals() const;
  // intervals() where the device's timestamps time the commands between them (Context::timestampsTrusted);
  // elsewhere one interval, `whole`, of `wallMs` (the submission's wall clock), so a method's stages add up
  // to its frame on every device.
  std::vector<std::pair<std::string, double>> intervalsOr(const std::string& whole, double wallMs) const;
};
Timer createTimer(Context& ctx, uint32_t capacity = 256);

// A one-shot command buffer: record, then submit() waits for completion.
class Commands {
 public:
  explicit Commands(Context& ctx, Timer* timer = nullptr);
  // Records into a command buffer of the caller's, already begun: nothing is allocated, begun, ended or
  // submitted; submit() is an error.
  Commands(Context& ctx, VkCommandBuffer recordInto);
  ~Commands();
  bool external() const { return external_; }
  Commands(const Commands&) = delete;
  Commands& operator=(const Commands&) = delete;

  VkCommandBuffer handle() const { return cb_; }
  // Dispatch `kernel` with its buffers (exactly kernel.bindings of them) and push constants.
  void dispatch(const Kernel& kernel, std::initializer_list<BufferRange> buffers, const void* push,
                uint32_t pushBytes, uint32_t gx, uint32_t gy = 1, uint32_t gz = 1);
  template <class P>
  void dispatch(const Kernel& kernel, std::initializer_list<BufferRange> buffers, const P& push,
                uint32_t gx, uint32_t gy = 1, uint32_t gz = 1) {
    dispatch(kernel, buffers, &push, sizeof(P), gx, gy, gz);
  }
  // Dispatch with the workgroup count read from `args` (3 x uint32 at `offset`) on the GPU.
  void dispatchIndirect(const Kernel& kernel, std::initializer_list<BufferRange> buffers, const void* push,
                        uint32_t pushBytes, const Buffer& args, VkDeviceSize offset = 0) {
    dispatchIndirect(kernel, buffers, push, pushBytes, args.buffer, offset);
  }
  void dispatchIndirect(const Kernel& kernel, std::initializer_list<BufferRange> buffers, const void* push,
                        uint32_t pushBytes, VkBuffer args, VkDeviceSize offset);
  void fill(const Buffer& b, uint32_t value, VkDeviceSize offset = 0, VkDeviceSize size = VK_WHOLE_SIZE);
  void copy(const Buffer& src, const Buffer& dst, VkDeviceSize bytes, VkDeviceSize srcOffset = 0,
            VkDeviceSize dstOffset = 0);
  // Full memory barrier between compute/transfer/indirect work (all writes visible to all later reads).
  void barrier();
  // Record a named timestamp (no-op without a timer).
  void mark(const std::string& name);
  // Submit and wait. The command buffer can be reused afterwards (begin() is called again).
  void submit();

 private:
  void begin();
  // CONESHADOW_PROFILE_DISPATCHES: submits what was recorded and times it against the kernel (context.cpp).
  void profileDispatch(const Kernel& kernel);
  Context& ctx_;
  Timer* timer_;
  VkCommandBuffer cb_ = VK_NULL_HANDLE;
  bool recording_ = false;
  bool external_ = false;
};

// 1-D dispatch maths: workgroups for `count` items of `groupSize`, split into (x, y) so neither exceeds
// the device's per-dimension limit. Kernels compute the flat id as (gl_WorkGroupID.y * gl_NumWorkGroups.x
// + gl_WorkGroupID.x) * groupSize + local id.
struct Grid {
  uint32_t x = 1, y = 1;
  uint64_t groups() const { return uint64_t(x) * y; }
};
Grid gridFor(uint64_t count, uint32_t groupSize, uint32_t maxPerDim);

}  // namespace cs::vk
