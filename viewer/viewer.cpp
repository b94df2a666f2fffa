// `coneshadow view`: the frame loop, the methods, the composite pass and the window's controls (viewer.h).
// docs/ARCHITECTURE.md, "The viewer".
#include "viewer/viewer.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>

#include "api/internal.h"
#include "coneshadow/coneshadow.h"
#include "core/image_io.h"
#include "harness/harness.h"
#include "judge/frame_output.h"
#include "judge/metrics.h"
#include "raster/gbuffer.vert.h"
#include "raster/gbuffer.frag.h"
#include "raster/raster.h"
#include "raster/raster_layout.h"
#include "viewer/composite.frag.h"
#include "viewer/composite.vert.h"
#include "viewer/composite_layout.h"
#include "viewer/display.h"
#include "viewer/reference_worker.h"
#include "viewer/script.h"
#include "vk/context.h"

namespace cs::viewer {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

constexpr VkFormat kGBufferFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr uint32_t kWarmUpFrames = 3;   // frames before the loop's counters count (pipelines, first uploads)
constexpr uint32_t kRestFrames = 3;     // frames with the view and light unchanged before the reference starts
constexpr size_t kGraphFrames = 120;

glm::vec4 rgb(const uint8_t c[3]) { return {float(c[0]), float(c[1]), float(c[2]), 255.0f}; }

std::string vec3Text(glm::vec3 v) {
  std::ostringstream os;
  os << v.x << "," << v.y << "," << v.z;
  return os.str();
}

// The camera orbited about its target by yaw (about `up`) and pitch (about the camera's right axis).
Camera orbited(const Camera& c, float yaw, float pitch) {
  const glm::vec3 up = glm::normalize(c.up);
  glm::vec3 offset = c.eye - c.target;
  const float r = glm::length(offset);
  if (r <= 0) return c;
  auto rotate = [](glm::vec3 v, glm::vec3 axis, float a) {
    return v * std::cos(a) + glm::cross(axis, v) * std::sin(a) + axis * glm::dot(axis, v) * (1 - std::cos(a));
  };
  offset = rotate(offset, up, yaw);
  glm::vec3 right = glm::cross(up, offset);
  if (glm::length(right) > 1e-6f * r) {
    const glm::vec3 pitched = rotate(offset, glm::normalize(right), pitch);
    if (std::abs(glm::dot(glm::normalize(pitched), up)) < 0.995f) offset = pitched;  // never over the pole
  }
  Camera out = c;
  out.eye = c.target + offset;
  return out;
}

// The ImGui Vulkan backend's device allocations (its font image, its vertex and index buffers): the backend
// is built with IMGUI_IMPL_VULKAN_NO_PROTOTYPES and gets its functions from loadUiFunction, whose
// vkAllocateMemory counts. Its heap allocations go through ImGui's allocator functions, which count too.
std::atomic<uint64_t> uiDeviceAllocations{0}, uiHeapAllocations{0};
PFN_vkAllocateMemory driverAllocateMemory = nullptr;

VKAPI_ATTR VkResult VKAPI_CALL countedAllocateMemory(VkDevice device, const VkMemoryAllocateInfo* info,
                                                     const VkAllocationCallbacks* callbacks, VkDeviceMemory* memory) {
  ++uiDeviceAllocations;
  return driverAllocateMemory(device, info, callbacks, memory);
}

PFN_vkVoidFunction loadUiFunction(const char* name, void* instance) {
  const PFN_vkVoidFunction f = vkGetInstanceProcAddr(*static_cast<VkInstance*>(instance), name);
  if (f && std::strcmp(name, "vkAllocateMemory") == 0) {
    driverAllocateMemory = reinterpret_cast<PFN_vkAllocateMemory>(f);
    return reinterpret_cast<PFN_vkVoidFunction>(countedAllocateMemory);
  }
  return f;
}

void* uiAlloc(size_t bytes, void*) {
  ++uiHeapAllocations;
  return std::malloc(bytes);
}
void uiFree(void* p, void*) { std::free(p); }

// One method as the loop runs it: the cone path through the public API, or a registry method.
struct Shown {
  const MethodInfo* info = nullptr;
  Settings settings;
  bool api = false;                       // the cone path through include/coneshadow/ (cone at its defaults)
  std::unique_ptr<ShadowMethod> method;   // a registry method (null for the API path)
  std::string error;                      // why it cannot run ("" = it runs)
  std::string title;                      // its name in the panels (made once: the frame allocates nothing)
  const std::string& label() const { return title; }
};

struct Counters {
  uint64_t submits = 0, presents = 0, allocations = 0, hostSyncs = 0;
  uint64_t uiDeviceAllocations = 0;  // the ImGui Vulkan backend's vkAllocateMemory calls
  uint64_t heap = 0;                 // operator new on the frame loop's thread (the coneshadow binary counts it)
  uint64_t uiHeap = 0;               // ImGui's own allocations (its allocator functions)
  uint64_t apiHeap = 0;              // of `heap`, those made inside coneshadow::Context::recordFrame
};

uint64_t heapNow() { return threadHeapAllocations ? threadHeapAllocations() : 0; }

class Viewer {
 public:
  explicit Viewer(ViewerSpec spec);
  ~Viewer();
  int run();

 private:
  // setup
  void createFrameResources();
  void createVisibilityImage();
  void createDisplayPass();
  void createCompositePipeline();
  void createGBufferPipeline();
  void createFramebuffers();
  void destroyFramebuffers();
  void initUi();
  // per frame
  void applyScript();
  void drawUi();
  void handleInput();
  Shown makeShown(size_t index, const Settings& settings);
  void selectMethod(size_t index, const Settings& settings);
  void selectRight(size_t index);  // the split screen's right half
  size_t methodEntry(const MethodInfo& info);  // its index in spec_.methods, added with its defaults when absent
  void runRegistryMethod(Shown& shown, std::vector<float>& mask, vk::Buffer& vis, MethodOutput& out);
  void recordFrame(VkCommandBuffer cb, uint32_t image);
  void afterFrame();
  void printConeGpuTimes() const;  // --stats: the last frame's GPU stage times of the cone path, a light each
  void requestReference();
  void updateError();
  void writeScreenshot(const std::string& path);
  Counters totals() const;
  void viewChanged() { ++viewGeneration_, restFrames_ = 0; }
  void setTime(double t);  // an animated scene posed at t: every path's geometry, a new view
  void setActive(std::vector<uint32_t> entries);  // the lights shown (table entries); the focus stays if shown
  void setFocus(uint32_t k);                      // the k-th light shown becomes the one the mask shows
  void syncLight() { table_[active_[focus_]] = light_; }
  void lightPanel();
  // The warm-up: the pipelines and first uploads, and the UI's vertex and index buffers, a set per
  // swapchain image, made the first time the image is drawn.
  uint64_t warmUpFrames() const { return std::max<uint64_t>(kWarmUpFrames, d_.images.size()); }
  void reserveUiBuffers();
  // The error on screen belongs to the view and the method shown.
  bool errorShown() const {
    return errorValid_ && reference_.generation == viewGeneration_ && errorView_ == viewGeneration_ && errorMethod_ == methodGeneration_;
  }

  ViewerSpec spec_;
  Display d_;
  std::unique_ptr<vk::Context> vk_;  // the registry methods' context on the viewer's device
  std::unique_ptr<coneshadow::Context> api_;
  std::unique_ptr<Raster> raster_;   // the registry methods' camera pass (made on first use)
  std::unique_ptr<ReferenceWorker> worker_;
  EpsilonPolicy policy_;
  std::vector<Camera> cameras_;
  size_t cameraIndex_ = 0;
  Camera camera_;
  // The light table: the run's lights, then the scene's other point lights (at most kMaxLights). active_:
  // the entries shown, in the frame's order (the visibility image's layers); focus_: the place in active_
  // of the light the mask, the diff, the light moves, the reference and the registry methods use, whose
  // position light_ holds while it moves (written back to the table by syncLight).
  std::vector<glm::vec3> table_, initialTable_;
  std::vector<std::string> tableNames_;
  std::vector<uint32_t> active_;
  uint32_t focus_ = 0;
  glm::vec3 light_{0};
  std::array<glm::vec4, kMaxLights + 1> frameLights_{};  // the active lights, then the focus light (the composite's)
  std::array<float, 3 * kMaxLights> lightXyz_{};         // the active lights as the public API takes them
  Shown shown_;
  size_t methodIndex_ = 0;
  Shown right_;           // split screen: the method of the right half
  size_t rightIndex_ = 0;
  bool split_ = false;
  uint32_t display_ = 0;
  bool hideUi_ = false, help_ = false;
  uint32_t mesh_ = 0;      // the scene's mesh in the public API's context
  double time_ = 0;        // an animated scene's time
  bool playing_ = false;

  // The frame's data, host-visible: the G-buffer the composite shades, the method's mask, the reference.
  DeviceScene geometry_;
  vk::Image position_, normal_, depth_;
  VkImage visibility_ = VK_NULL_HANDLE;  // a layer a light of the table (vk::createImage makes one layer)
  VkDeviceMemory visibilityMemory_ = VK_NULL_HANDLE;
  vk::Buffer posBuf_, nrmBuf_, visBuf_, visBuf2_, refBuf_, bandBuf_, captureBuf_, lightBuf_;
  DeviceGBuffer registryGBuffer_;
  GBuffer host_;                  // the frame's G-buffer on the host (the reference's and the error's input)
  std::vector<float> hostMask_, hostMask2_;  // the masks on the host (the left method's, the right's)
  MethodOutput lastOutput_, rightOutput_;    // the registry methods' last frames
  bool visibilityInitialised_ = false;

  VkRenderPass gbufferPass_ = VK_NULL_HANDLE, displayPass_ = VK_NULL_HANDLE;
  VkFramebuffer gbufferFb_ = VK_NULL_HANDLE;
  std::vector<VkFramebuffer> displayFbs_;
  VkPipelineLayout gbufferLayout_ = VK_NULL_HANDLE, compositeLayout_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout compositeSet_ = VK_NULL_HANDLE;
  VkPipeline gbufferPipeline_ = VK_NULL_HANDLE, compositePipeline_ = VK_NULL_HANDLE;
  VkShaderModule modules_[4] = {};
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkFence frameDone_ = VK_NULL_HANDLE;
  VkSemaphore imageReady_ = VK_NULL_HANDLE;
  std::vector<VkSemaphore> renderDone_;
  VkDescriptorPool uiPool_ = VK_NULL_HANDLE;
  bool uiReady_ = false;

  // the loop's state
  uint64_t frame_ = 0;
  uint64_t viewGeneration_ = 1, methodGeneration_ = 1;
  uint32_t restFrames_ = 0;
  bool frameInFlight_ = false, captureInFlight_ = false;
  std::string capturePath_;
  bool needSnapshot_ = false;     // the next finished frame's G-buffer and mask go to the host
  uint64_t snapshotGeneration_ = 0, snapshotMethodGeneration_ = 0;
  ReferenceAnswer reference_;     // the newest answer (generation 0: none)
  ErrorStats error_;
  bool errorValid_ = false;
  uint64_t errorView_ = 0, errorMethod_ = 0;
  std::vector<ScriptStep> script_;
  size_t scriptPos_ = 0;
  uint32_t scriptWait_ = 0;
  bool scriptWaitReference_ = false, quit_ = false;
  std::string status_;

  // timings and counters
  float frameMs_[kGraphFrames] = {};
  size_t graphPos_ = 0;
  double lastFrameMs_ = 0, recordMs_ = 0, waitMs_ = 0, methodMs_ = 0, rasterMs_ = 0;
  double acquireMs_ = 0, presentMs_ = 0;  // the calls' own wall time (on lavapipe the present copies the image out)
  double sumAcquireMs_ = 0, sumPresentMs_ = 0, sumWaitMs_ = 0;  // over the steady frames
  Clock::time_point lastFrameStart_ = Clock::now();
  Counters mine_;                 // the viewer's own submissions and presents
  Counters steady_;               // summed over frames past the warm-up with nothing changed
  uint64_t steadyFrames_ = 0;
  // Host allocations over the steady frames that hand nothing to or from the reference worker and write
  // no screenshot (those copy a frame or a file's worth by design, once a view).
  uint64_t quietFrames_ = 0, quietHeap_ = 0, quietUiHeap_ = 0, quietApiHeap_ = 0;
  bool frameEvent_ = false;       // this frame handed work to or from the worker, or wrote a screenshot
  std::vector<double> steadyMs_;  // each steady frame's wall time, start of the loop to its fence (reserved)
  std::vector<double> idleMs_;    // the same, of the steady frames during which the reference worker was idle
};

Viewer::Viewer(ViewerSpec spec) : spec_(std::move(spec)) {
  CS_CHECK(!spec_.methods.empty(), "the viewer needs a method");
  display_ = spec_.display;
  hideUi_ = spec_.hideUi;
  if (!spec_.script.empty()) script_ = loadScript(spec_.script);  // before the window: a bad script opens nothing

  // The views: the scene's cameras (the built-in scene's are its named views), or an automatic one.
  cameras_ = spec_.scene.cameras;
  if (cameras_.empty()) {
    cameras_.push_back(automaticCamera(spec_.scene));
    cameras_.back().name = "auto";
  }
  if (!spec_.view.empty()) {
    auto it = std::find_if(cameras_.begin(), cameras_.end(), [&](const Camera& c) { return c.name == spec_.view; });
    if (it == cameras_.end()) {
      std::string all;
      for (const Camera& c : cameras_) all += (all.empty() ? "" : ", ") + c.name;
      throw UsageError("scene " + spec_.scene.name + " has no view '" + spec_.view + "' (views: " + all + ")");
    }
    cameraIndex_ = size_t(it - cameras_.begin());
  }
  camera_ = cameras_[cameraIndex_];
  CS_CHECK(!spec_.lights.empty(), "the viewer needs a light");
  if (spec_.lights.size() > kMaxLights)
    throw UsageError("the viewer shows up to " + std::to_string(kMaxLights) + " lights at once; scene " + spec_.scene.name +
                     " gives " + std::to_string(spec_.lights.size()) + " (give some with --light X,Y,Z)");
  auto sceneLightName = [&](glm::vec3 p) -> std::string {
    for (const PointLight& l : spec_.scene.lights)
      if (l.position == p) return l.name.empty() ? vec3Text(p) : l.name;
    return "";
  };
  for (size_t i = 0; i < spec_.lights.size(); ++i) {
    table_.push_back(spec_.lights[i]);
    const std::string name = sceneLightName(spec_.lights[i]);
    tableNames_.push_back(std::to_string(i) + ": " + (name.empty() ? "--light " + vec3Text(spec_.lights[i]) : name));
    active_.push_back(uint32_t(i));
  }
  for (const PointLight& l : spec_.scene.lights)
    if (table_.size() < kMaxLights && std::find(table_.begin(), table_.end(), l.position) == table_.end()) {
      tableNames_.push_back(std::to_string(table_.size()) + ": " + (l.name.empty() ? vec3Text(l.position) : l.name));
      table_.push_back(l.position);
    }
  initialTable_ = table_;
  light_ = table_[active_[focus_]];
  policy_ = EpsilonPolicy::forScene(spec_.scene);

  openDisplay(d_, spec_.width, spec_.height, spec_.device, "coneshadow view — " + spec_.scene.name);
  vk::AdoptedDevice a{d_.instance, d_.physical, d_.device, d_.queueFamily, vkGetInstanceProcAddr};
  vk_ = vk::shareDevice(a, d_.queue);
  vk_->geometryShader = d_.geometryShader;
  vk_->robustBufferAccess = d_.robustBufferAccess;
  coneshadow::Options o;
  o.framesInFlight = 1;  // the loop waits for each frame before recording the next
  o.maxLights = uint32_t(table_.size());
  api_ = coneshadow::Context::create({d_.instance, d_.physical, d_.device, d_.queueFamily, vkGetInstanceProcAddr}, o);
  mesh_ = api_->createMesh(&spec_.scene.positions[0].x, spec_.scene.positions.size(),
                                         spec_.scene.indices.data(), spec_.scene.indices.size());
  api_->createInstance(mesh_, coneshadow::kIdentity);
  geometry_.update(*vk_, spec_.scene, geometryRevision(spec_.scene));

  createFrameResources();
  createDisplayPass();
  createGBufferPipeline();
  createCompositePipeline();
  createFramebuffers();
  initUi();
  worker_ = std::make_unique<ReferenceWorker>(policy_);
  if (spec_.animation) time_ = spec_.animation->start;
  selectMethod(0, spec_.methods[0].second);
}

Viewer::~Viewer() {
  if (d_.device) vkDeviceWaitIdle(d_.device);
  worker_.reset();
  if (uiReady_) {
    ImGui_ImplVulkan_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  VkDevice dev = d_.device;
  if (!dev) return;
  destroyFramebuffers();
  if (uiPool_) vkDestroyDescriptorPool(dev, uiPool_, nullptr);
  if (gbufferFb_) vkDestroyFramebuffer(dev, gbufferFb_, nullptr);
  for (VkPipeline p : {gbufferPipeline_, compositePipeline_})
    if (p) vkDestroyPipeline(dev, p, nullptr);
  for (VkPipelineLayout l : {gbufferLayout_, compositeLayout_})
    if (l) vkDestroyPipelineLayout(dev, l, nullptr);
  if (compositeSet_) vkDestroyDescriptorSetLayout(dev, compositeSet_, nullptr);
  for (VkShaderModule m : modules_)
    if (m) vkDestroyShaderModule(dev, m, nullptr);
  for (VkRenderPass r : {gbufferPass_, displayPass_})
    if (r) vkDestroyRenderPass(dev, r, nullptr);
  for (VkSemaphore s : renderDone_) vkDestroySemaphore(dev, s, nullptr);
  if (imageReady_) vkDestroySemaphore(dev, imageReady_, nullptr);
  if (frameDone_) vkDestroyFence(dev, frameDone_, nullptr);
  if (pool_) vkDestroyCommandPool(dev, pool_, nullptr);
  shown_.method.reset();
  right_.method.reset();
  raster_.reset();
  registryGBuffer_ = {};
  for (vk::Image* i : {&position_, &normal_, &depth_}) i->reset();
  if (visibility_) vkDestroyImage(dev, visibility_, nullptr);
  if (visibilityMemory_) vkFreeMemory(dev, visibilityMemory_, nullptr);
  for (vk::Buffer* b : {&posBuf_, &nrmBuf_, &visBuf_, &visBuf2_, &refBuf_, &bandBuf_, &captureBuf_, &lightBuf_}) b->reset();
  geometry_ = {};
  api_.reset();
  vk_.reset();
}

void Viewer::createFrameResources() {
  const uint32_t w = spec_.width, h = spec_.height;
  const VkDeviceSize px = VkDeviceSize(w) * h;
  constexpr VkImageUsageFlags target = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  position_ = vk::createImage(*vk_, w, h, kGBufferFormat, target, VK_IMAGE_ASPECT_COLOR_BIT);
  normal_ = vk::createImage(*vk_, w, h, kGBufferFormat, target, VK_IMAGE_ASPECT_COLOR_BIT);
  depth_ = vk::createImage(*vk_, w, h, VK_FORMAT_D32_SFLOAT, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT);
  createVisibilityImage();
  const VkDeviceSize layers = table_.size();
  posBuf_ = vk::createBuffer(*vk_, px * 16, vk::Memory::HostVisible);
  nrmBuf_ = vk::createBuffer(*vk_, px * 16, vk::Memory::HostVisible);
  visBuf_ = vk::createBuffer(*vk_, px * 4 * layers, vk::Memory::HostVisible);
  visBuf2_ = vk::createBuffer(*vk_, px * 4 * layers, vk::Memory::HostVisible);
  lightBuf_ = vk::createBuffer(*vk_, sizeof(frameLights_), vk::Memory::HostVisible);
  refBuf_ = vk::createBuffer(*vk_, px * 4, vk::Memory::HostVisible);
  bandBuf_ = vk::createBuffer(*vk_, px * 4, vk::Memory::HostVisible);
  host_.width = w, host_.height = h;
  host_.position.resize(px);
  host_.normal.resize(px);
  hostMask_.resize(px);
  hostMask2_.resize(px);

  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pi.queueFamilyIndex = d_.queueFamily;
  VK_CHECK(vkCreateCommandPool(d_.device, &pi, nullptr, &pool_));
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = pool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VK_CHECK(vkAllocateCommandBuffers(d_.device, &ai, &cmd_));
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VK_CHECK(vkCreateFence(d_.device, &fi, nullptr, &frameDone_));
  VkSemaphoreCreateInfo si{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  VK_CHECK(vkCreateSemaphore(d_.device, &si, nullptr, &imageReady_));
}

// The public API's visibility image: a layer a light of the table, the API writes it, the copies read it.
void Viewer::createVisibilityImage() {
  VkImageCreateInfo ii{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ii.imageType = VK_IMAGE_TYPE_2D;
  ii.format = VK_FORMAT_R32_SFLOAT;
  ii.extent = {spec_.width, spec_.height, 1};
  ii.mipLevels = 1;
  ii.arrayLayers = uint32_t(table_.size());
  ii.samples = VK_SAMPLE_COUNT_1_BIT;
  ii.tiling = VK_IMAGE_TILING_OPTIMAL;
  ii.usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  ii.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VK_CHECK(vkCreateImage(d_.device, &ii, nullptr, &visibility_));
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(d_.device, visibility_, &req);
  VkPhysicalDeviceMemoryProperties props;
  vkGetPhysicalDeviceMemoryProperties(d_.physical, &props);
  uint32_t type = UINT32_MAX;
  for (VkMemoryPropertyFlags want : {VkMemoryPropertyFlags(VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT), VkMemoryPropertyFlags(0)})
    for (uint32_t t = 0; t < props.memoryTypeCount && type == UINT32_MAX; ++t)
      if ((req.memoryTypeBits & (1u << t)) && (props.memoryTypes[t].propertyFlags & want) == want) type = t;
  if (type == UINT32_MAX) throw Error("no memory type for the visibility image", vk_->deviceName());
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = type;
  const VkResult r = vkAllocateMemory(d_.device, &ai, nullptr, &visibilityMemory_);
  ++mine_.allocations;
  if (r != VK_SUCCESS)
    throw Error("cannot allocate the visibility image (" + std::to_string(table_.size()) + " lights)", vk_->deviceName(),
                "lower the resolution or give fewer lights");
  VK_CHECK(vkBindImageMemory(d_.device, visibility_, visibilityMemory_, 0));
}

void Viewer::createDisplayPass() {
  VkAttachmentDescription att{};
  att.format = d_.format;
  att.samples = VK_SAMPLE_COUNT_1_BIT;
  att.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  att.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  att.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  att.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  att.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  att.finalLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = 1;
  sub.pColorAttachments = &ref;
  VkSubpassDependency dep{};  // the acquire semaphore's wait is at colour output
  dep.srcSubpass = VK_SUBPASS_EXTERNAL;
  dep.dstSubpass = 0;
  dep.srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  dep.dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  dep.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  VkRenderPassCreateInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  rp.attachmentCount = 1;
  rp.pAttachments = &att;
  rp.subpassCount = 1;
  rp.pSubpasses = &sub;
  rp.dependencyCount = 1;
  rp.pDependencies = &dep;
  VK_CHECK(vkCreateRenderPass(d_.device, &rp, nullptr, &displayPass_));
}

// The camera pass of raster/ (its shaders, its push constants), recorded into the viewer's own frame so
// that the cone path's frame is one submission; the images end in GENERAL, as the public API takes them.
void Viewer::createGBufferPipeline() {
  VkAttachmentDescription att[3]{};
  VkAttachmentReference colors[2];
  for (uint32_t i = 0; i < 3; ++i) {
    const bool depth = i == 2;
    att[i].format = depth ? VK_FORMAT_D32_SFLOAT : kGBufferFormat;
    att[i].samples = VK_SAMPLE_COUNT_1_BIT;
    att[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    att[i].storeOp = depth ? VK_ATTACHMENT_STORE_OP_DONT_CARE : VK_ATTACHMENT_STORE_OP_STORE;
    att[i].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    att[i].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    att[i].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    att[i].finalLayout = depth ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_GENERAL;
    if (!depth) colors[i] = {i, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  }
  VkAttachmentReference depthRef{2, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = 2;
  sub.pColorAttachments = colors;
  sub.pDepthStencilAttachment = &depthRef;
  VkSubpassDependency deps[2]{};
  deps[0].srcSubpass = 0;  // the writes visible to the copies (the API's, the viewer's)
  deps[0].dstSubpass = VK_SUBPASS_EXTERNAL;
  deps[0].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[0].dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
  deps[0].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  deps[0].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  deps[1].srcSubpass = VK_SUBPASS_EXTERNAL;  // the last frame's copies out of the images are done
  deps[1].dstSubpass = 0;
  deps[1].srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
  deps[1].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT;
  deps[1].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  VkRenderPassCreateInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  rp.attachmentCount = 3;
  rp.pAttachments = att;
  rp.subpassCount = 1;
  rp.pSubpasses = &sub;
  rp.dependencyCount = 2;
  rp.pDependencies = deps;
  VK_CHECK(vkCreateRenderPass(d_.device, &rp, nullptr, &gbufferPass_));

  VkImageView views[3] = {position_.view, normal_.view, depth_.view};
  VkFramebufferCreateInfo fi{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  fi.renderPass = gbufferPass_;
  fi.attachmentCount = 3;
  fi.pAttachments = views;
  fi.width = spec_.width;
  fi.height = spec_.height;
  fi.layers = 1;
  VK_CHECK(vkCreateFramebuffer(d_.device, &fi, nullptr, &gbufferFb_));

  modules_[0] = vk::createShaderModule(*vk_, spv_gbuffer_vert, sizeof(spv_gbuffer_vert));
  modules_[1] = vk::createShaderModule(*vk_, spv_gbuffer_frag, sizeof(spv_gbuffer_frag));
  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(RasterPush)};
  VkPipelineLayoutCreateInfo li{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  VK_CHECK(vkCreatePipelineLayout(d_.device, &li, nullptr, &gbufferLayout_));
  vk::TrianglePipelineDesc desc;
  desc.vert = modules_[0];
  desc.frag = modules_[1];
  desc.layout = gbufferLayout_;
  desc.renderPass = gbufferPass_;
  desc.vertexStreams = 2;
  desc.colorAttachments = 2;
  gbufferPipeline_ = vk::createTrianglePipeline(*vk_, desc);
}

void Viewer::createCompositePipeline() {
  VkDescriptorSetLayoutBinding b[6];
  for (uint32_t i = 0; i < 6; ++i) b[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo si{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  si.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR;
  si.bindingCount = 6;
  si.pBindings = b;
  VK_CHECK(vkCreateDescriptorSetLayout(d_.device, &si, nullptr, &compositeSet_));
  VkPushConstantRange range{VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(CompositePush)};
  VkPipelineLayoutCreateInfo li{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  li.setLayoutCount = 1;
  li.pSetLayouts = &compositeSet_;
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  VK_CHECK(vkCreatePipelineLayout(d_.device, &li, nullptr, &compositeLayout_));

  modules_[2] = vk::createShaderModule(*vk_, spv_composite_vert, sizeof(spv_composite_vert));
  modules_[3] = vk::createShaderModule(*vk_, spv_composite_frag, sizeof(spv_composite_frag));
  vk::TrianglePipelineDesc desc;
  desc.vert = modules_[2];
  desc.frag = modules_[3];
  desc.layout = compositeLayout_;
  desc.renderPass = displayPass_;
  desc.vertexStreams = 0;  // one triangle over the window, made by the vertex stage
  desc.depth = false;
  compositePipeline_ = vk::createTrianglePipeline(*vk_, desc);
}

void Viewer::createFramebuffers() {
  for (VkImageView v : d_.views) {
    VkFramebufferCreateInfo fi{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fi.renderPass = displayPass_;
    fi.attachmentCount = 1;
    fi.pAttachments = &v;
    fi.width = d_.extent.width;
    fi.height = d_.extent.height;
    fi.layers = 1;
    VkFramebuffer fb;
    VK_CHECK(vkCreateFramebuffer(d_.device, &fi, nullptr, &fb));
    displayFbs_.push_back(fb);
  }
  VkSemaphoreCreateInfo si{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  while (renderDone_.size() < d_.images.size()) {
    VkSemaphore s;
    VK_CHECK(vkCreateSemaphore(d_.device, &si, nullptr, &s));
    renderDone_.push_back(s);
  }
  captureBuf_ = vk::createBuffer(*vk_, VkDeviceSize(d_.extent.width) * d_.extent.height * 4, vk::Memory::HostVisible);
}

void Viewer::destroyFramebuffers() {
  for (VkFramebuffer fb : displayFbs_) vkDestroyFramebuffer(d_.device, fb, nullptr);
  displayFbs_.clear();
}

void checkUiResult(VkResult r) {
  if (r != VK_SUCCESS) vk::fail(r, "the ImGui Vulkan backend", __FILE__, __LINE__);
}

void Viewer::initUi() {
  IMGUI_CHECKVERSION();
  ImGui::SetAllocatorFunctions(uiAlloc, uiFree);
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // the window's layout is not written next to the user's files
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForVulkan(d_.window, true);
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 8};
  VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pi.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  pi.maxSets = 8;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(d_.device, &pi, nullptr, &uiPool_));
  ImGui_ImplVulkan_InitInfo init{};
  init.Instance = d_.instance;
  init.PhysicalDevice = d_.physical;
  init.Device = d_.device;
  init.QueueFamily = d_.queueFamily;
  init.Queue = d_.queue;
  init.DescriptorPool = uiPool_;
  init.MinImageCount = 2;
  init.ImageCount = uint32_t(d_.images.size());
  init.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
  init.CheckVkResultFn = checkUiResult;
  if (!ImGui_ImplVulkan_LoadFunctions(loadUiFunction, &d_.instance))
    throw Error("the ImGui Vulkan backend cannot load its Vulkan functions", vk_->deviceName());
  ImGui_ImplVulkan_Init(&init, displayPass_);
  uiReady_ = true;
  // The font atlas: the one submission outside the frame loop.
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(cmd_, &bi));
  ImGui_ImplVulkan_CreateFontsTexture(cmd_);
  VK_CHECK(vkEndCommandBuffer(cmd_));
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd_;
  VK_CHECK(vkQueueSubmit(d_.queue, 1, &si, frameDone_));
  VK_CHECK(vkWaitForFences(d_.device, 1, &frameDone_, VK_TRUE, UINT64_MAX));
  VK_CHECK(vkResetFences(d_.device, 1, &frameDone_));
  ImGui_ImplVulkan_DestroyFontUploadObjects();
}

Shown Viewer::makeShown(size_t index, const Settings& settings) {
  const MethodInfo& info = *spec_.methods[index].first;
  if (info.check) info.check(settings);  // UsageError: the caller keeps the method shown
  Shown next;
  next.info = &info;
  next.settings = settings;
  next.api = info.name == "cone" && settings.values().empty();
  next.title = next.api ? info.name + " (public API)" : info.name;
  if (!next.api) {
    next.error = unsupportedOn(info, *vk_, settings);
    if (next.error.empty()) next.method = info.make(info.usesDevice ? vk_.get() : nullptr, settings);
    if (!raster_) raster_ = std::make_unique<Raster>(*vk_, spec_.scene);
  }
  return next;
}

void Viewer::selectMethod(size_t index, const Settings& settings) {
  shown_ = makeShown(index, settings);
  methodIndex_ = index;
  spec_.methods[index].second = settings;
  ++methodGeneration_;
  restFrames_ = 0;
}

void Viewer::selectRight(size_t index) {
  right_ = makeShown(index, spec_.methods[index].second);
  rightIndex_ = index;
  restFrames_ = 0;
}

size_t Viewer::methodEntry(const MethodInfo& info) {
  auto it = std::find_if(spec_.methods.begin(), spec_.methods.end(), [&](const auto& e) { return e.first == &info; });
  if (it != spec_.methods.end()) return size_t(it - spec_.methods.begin());
  spec_.methods.push_back({&info, Settings(info.name)});
  return spec_.methods.size() - 1;
}

void Viewer::setActive(std::vector<uint32_t> entries) {
  syncLight();
  const uint32_t focused = active_[focus_];
  entries.erase(std::unique(entries.begin(), entries.end()), entries.end());
  if (entries.empty()) return;  // one light stays shown
  active_ = std::move(entries);
  const auto it = std::find(active_.begin(), active_.end(), focused);
  focus_ = it == active_.end() ? 0 : uint32_t(it - active_.begin());
  light_ = table_[active_[focus_]];
  viewChanged();
}

void Viewer::setFocus(uint32_t k) {
  syncLight();
  focus_ = k;
  light_ = table_[active_[focus_]];
  viewChanged();
}

void Viewer::setTime(double t) {
  const Animation& a = *spec_.animation;
  const double span = a.end - a.start;
  time_ = span > 0 ? a.start + std::fmod(std::fmod(t - a.start, span) + span, span) : a.start;
  a.pose(time_, spec_.scene);
  api_->updateMesh(mesh_, &spec_.scene.positions[0].x, spec_.scene.positions.size(), spec_.scene.indices.data(),
                   spec_.scene.indices.size());
  geometry_.update(*vk_, spec_.scene, geometryRevision(spec_.scene));
  if (raster_) raster_->setGeometry(spec_.scene);
  viewChanged();
}

// The script's commands up to its next wait.
void Viewer::applyScript() {
  if (scriptWait_ > 0) {
    --scriptWait_;
    return;
  }
  if (scriptWaitReference_) {
    if (reference_.generation != viewGeneration_ && reference_.failure.empty()) return;
    scriptWaitReference_ = false;
  }
  while (scriptPos_ < script_.size() && !scriptWait_ && !scriptWaitReference_) {
    const ScriptStep& s = script_[scriptPos_++];
    const std::string where = spec_.script + ":" + std::to_string(s.line);
    switch (s.kind) {
      case ScriptStep::Method: {
        const MethodInfo& info = methodOrUsageError(s.name);
        selectMethod(methodEntry(info), Settings(info.name));
        break;
      }
      case ScriptStep::Split:
        split_ = s.name != "off";
        if (split_) selectRight(methodEntry(methodOrUsageError(s.name)));
        break;
      case ScriptStep::Set:
        selectMethod(methodIndex_, shown_.settings.with(s.name, s.value));
        break;
      case ScriptStep::Light: light_ = s.v, viewChanged(); break;
      case ScriptStep::Lights: {
        std::vector<uint32_t> entries = s.lights;
        if (entries.empty())
          for (uint32_t i = 0; i < table_.size(); ++i) entries.push_back(i);
        for (uint32_t k : entries)
          if (k >= table_.size())
            throw Error("no light " + std::to_string(k) + " (the table has " + std::to_string(table_.size()) + ")", where,
                        "number the run's lights (--light, in order) and then the scene's point lights from 0");
        setActive(entries);
        break;
      }
      case ScriptStep::ShowLight:
        if (s.lights[0] >= active_.size())
          throw Error("no light " + std::to_string(s.lights[0]) + " among the " + std::to_string(active_.size()) + " shown", where,
                      "count the lights of the last `lights` command from 0");
        setFocus(s.lights[0]);
        break;
      case ScriptStep::MoveLight: light_ += s.v, viewChanged(); break;
      case ScriptStep::Camera: {
        auto it = std::find_if(cameras_.begin(), cameras_.end(), [&](const Camera& c) { return c.name == s.name; });
        if (it == cameras_.end()) throw Error("no view '" + s.name + "' in the scene", where, "name one of the scene's cameras");
        cameraIndex_ = size_t(it - cameras_.begin());
        camera_ = *it;
        viewChanged();
        break;
      }
      case ScriptStep::Orbit: camera_ = orbited(camera_, s.v.x, s.v.y), viewChanged(); break;
      case ScriptStep::Display:
        display_ = uint32_t(std::find(std::begin(kDisplayNames), std::end(kDisplayNames), s.name) - std::begin(kDisplayNames));
        break;
      case ScriptStep::Time:
        if (!spec_.animation) throw Error("the scene does not move", where, "give `time` for an animated scene only");
        playing_ = false;
        setTime(s.v.x);
        break;
      case ScriptStep::Wait: scriptWait_ = s.frames; break;
      case ScriptStep::WaitReference: scriptWaitReference_ = true; break;
      case ScriptStep::Screenshot: capturePath_ = s.name; return;  // of this frame: the next commands wait for the next
      case ScriptStep::Quit: quit_ = true; return;
    }
  }
}

void Viewer::handleInput() {
  ImGuiIO& io = ImGui::GetIO();
  if (!io.WantCaptureKeyboard) {
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Tab)) && spec_.methods.size() > 1)
      selectMethod((methodIndex_ + 1) % spec_.methods.size(), spec_.methods[(methodIndex_ + 1) % spec_.methods.size()].second);
    for (uint32_t k = 0; k < 3; ++k)
      if (ImGui::IsKeyPressed(GLFW_KEY_1 + int(k))) display_ = k;
    if (ImGui::IsKeyPressed(GLFW_KEY_U)) hideUi_ = !hideUi_;
    if (spec_.animation && ImGui::IsKeyPressed(GLFW_KEY_SPACE)) playing_ = !playing_;
    if (spec_.animation && ImGui::IsKeyPressed(GLFW_KEY_PERIOD))
      playing_ = false, setTime(time_ + (spec_.animation->end - spec_.animation->start) / 100);
    if (ImGui::IsKeyPressed(GLFW_KEY_V)) {
      split_ = !split_;
      if (split_) selectRight(spec_.methods.size() > 1 ? (methodIndex_ + 1) % spec_.methods.size() : methodIndex_);
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_H) || ImGui::IsKeyPressed(GLFW_KEY_F1)) help_ = !help_;
    if (ImGui::IsKeyPressed(GLFW_KEY_P)) capturePath_ = "coneshadow_view_" + std::to_string(frame_) + ".png";
    if (ImGui::IsKeyPressed(GLFW_KEY_R)) {
      camera_ = cameras_[cameraIndex_];
      table_ = initialTable_;
      light_ = table_[active_[focus_]];
      viewChanged();
    }
    // Fly: WASD along the view, Q/E down and up, a hundredth of the scene's diagonal a frame.
    const glm::vec3 forward = glm::normalize(camera_.target - camera_.eye);
    const glm::vec3 right = glm::normalize(glm::cross(forward, camera_.up));
    const float step = 0.01f * spec_.scene.diagonal();
    glm::vec3 move(0);
    if (ImGui::IsKeyDown(GLFW_KEY_W)) move += forward;
    if (ImGui::IsKeyDown(GLFW_KEY_S)) move -= forward;
    if (ImGui::IsKeyDown(GLFW_KEY_D)) move += right;
    if (ImGui::IsKeyDown(GLFW_KEY_A)) move -= right;
    if (ImGui::IsKeyDown(GLFW_KEY_E)) move += glm::normalize(camera_.up);
    if (ImGui::IsKeyDown(GLFW_KEY_Q)) move -= glm::normalize(camera_.up);
    if (move != glm::vec3(0)) camera_.eye += move * step, camera_.target += move * step, viewChanged();
  }
  if (io.WantCaptureMouse) return;
  const ImVec2 delta = io.MouseDelta;
  if (ImGui::IsMouseDown(ImGuiMouseButton_Left) && (delta.x != 0 || delta.y != 0)) {
    if (io.KeyShift) {  // drag the light in the plane facing the camera
      const glm::vec3 forward = glm::normalize(camera_.target - camera_.eye);
      const glm::vec3 right = glm::normalize(glm::cross(forward, camera_.up));
      const glm::vec3 up = glm::cross(right, forward);
      const float perPixel = 2.0f * glm::length(light_ - camera_.eye) * std::tan(camera_.yfov / 2) / float(spec_.height);
      light_ += (right * delta.x - up * delta.y) * perPixel;
    } else {
      camera_ = orbited(camera_, -delta.x * 0.01f, -delta.y * 0.01f);
    }
    viewChanged();
  }
  if (io.MouseWheel != 0) {
    camera_.eye = camera_.target + (camera_.eye - camera_.target) * std::pow(0.9f, io.MouseWheel);
    viewChanged();
  }
}

// The lights: the one the mask shows (typed or dragged), the table's entries shown at once, what each
// display and method does with them. Labels from fixed buffers: the steady frame allocates nothing.
void Viewer::lightPanel() {
  float l[3] = {light_.x, light_.y, light_.z};
  if (ImGui::DragFloat3("light", l, 0.002f * spec_.scene.diagonal())) light_ = {l[0], l[1], l[2]}, viewChanged();
  const uint32_t n = uint32_t(active_.size());
  if (ImGui::BeginCombo("lights", n == 1 ? tableNames_[active_[0]].c_str() : "several")) {
    for (uint32_t e = 0; e < table_.size(); ++e) {
      bool on = std::find(active_.begin(), active_.end(), e) != active_.end();
      if (ImGui::Checkbox(tableNames_[e].c_str(), &on)) {
        std::vector<uint32_t> next;
        for (uint32_t a : active_)
          if (a != e) next.push_back(a);
        if (on) next.push_back(e);
        std::sort(next.begin(), next.end());
        setActive(next);
      }
    }
    if (ImGui::Selectable("all")) {
      std::vector<uint32_t> all(table_.size());
      for (uint32_t e = 0; e < all.size(); ++e) all[e] = e;
      setActive(all);
    }
    ImGui::EndCombo();
  }
  if (n > 1) {
    if (ImGui::BeginCombo("mask light", tableNames_[active_[focus_]].c_str())) {
      for (uint32_t k = 0; k < n; ++k)
        if (ImGui::Selectable(tableNames_[active_[k]].c_str(), k == focus_)) setFocus(k);
      ImGui::EndCombo();
    }
    if (shown_.api)
      ImGui::TextDisabled("shaded: %u lights summed; mask, diff, light moves: %s", n, tableNames_[active_[focus_]].c_str());
  }
  if (!shown_.api || (split_ && !right_.api))
    ImGui::TextDisabled("registry methods: one light a frame: %s", tableNames_[active_[focus_]].c_str());
}

// The ImGui backend sizes its vertex and index buffers to each frame's panels, so panels that grow by a few
// vertices (a longer number, the reference's lines) would reallocate them in a steady frame. During the
// warm-up every swapchain image's set is made room for kUiReservedRects empty rectangles (nothing drawn);
// they grow again only for panels past that.
void Viewer::reserveUiBuffers() {
  constexpr int kUiReservedRects = 8192;  // 32K vertices, 48K indices: several times the panels' size
  ImDrawList* list = ImGui::GetForegroundDrawList();
  list->PrimReserve(6 * kUiReservedRects, 4 * kUiReservedRects);
  for (int i = 0; i < kUiReservedRects; ++i) list->PrimRect(ImVec2(0, 0), ImVec2(0, 0), 0);
}

// The window's panels; every method's settings come from its SettingSpecs.
void Viewer::drawUi() {
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowBgAlpha(0.8f);
  ImGui::Begin("coneshadow", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  ImGui::PushItemWidth(150);
  if (ImGui::BeginCombo("method", shown_.label().c_str())) {
    for (const MethodInfo& m : registeredMethods())
      if (ImGui::Selectable(m.name.c_str(), &m == shown_.info)) {
        try {
          const size_t index = methodEntry(m);
          selectMethod(index, spec_.methods[index].second);
        } catch (const std::exception& e) {
          status_ = e.what();
        }
      }
    ImGui::EndCombo();
  }
  // The method's settings, from its SettingSpecs: a switch is a checkbox, an enumeration a list, the
  // rest a text field applied on Enter (the method checks it; a bad value is shown and not taken).
  auto settingWidgets = [&](bool tuning) {
    for (const SettingSpec& s : shown_.info->settings) {
      if (s.tuning != tuning) continue;
      const bool has = shown_.settings.has(s.name);
      const std::string value = has ? shown_.settings.values().at(s.name) : "";
      std::string next = value;
      bool changed = false, remove = false;
      const std::string label = s.name;
      if (s.value.empty()) {
        bool on = has;
        if (ImGui::Checkbox(label.c_str(), &on)) changed = true, remove = !on;
      } else if (!s.choices.empty()) {
        if (ImGui::BeginCombo(label.c_str(), has ? value.c_str() : "(default)")) {
          if (ImGui::Selectable("(default)", !has)) changed = true, remove = true;
          for (const std::string& c : s.choices)
            if (ImGui::Selectable(c.c_str(), has && equalsIgnoringCase(c, value))) changed = true, next = c;
          ImGui::EndCombo();
        }
      } else {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%s", value.c_str());
        if (ImGui::InputTextWithHint(label.c_str(), s.value.c_str(), buf, sizeof buf, ImGuiInputTextFlags_EnterReturnsTrue))
          changed = true, next = buf, remove = next.empty();
      }
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", s.help.c_str());
      if (changed) {
        try {
          selectMethod(methodIndex_, remove ? shown_.settings.without(s.name) : shown_.settings.with(s.name, next));
          status_.clear();
        } catch (const std::exception& e) {
          status_ = e.what();
        }
      }
    }
  };
  if (!shown_.info->settings.empty() && ImGui::CollapsingHeader("settings")) {
    settingWidgets(false);
    if (ImGui::TreeNode("tuning (never changes the mask)")) {
      settingWidgets(true);
      ImGui::TreePop();
    }
  }
  if (ImGui::Checkbox("split screen", &split_) && split_) {
    try {
      selectRight(spec_.methods.size() > 1 ? (methodIndex_ + 1) % spec_.methods.size() : methodIndex_);
    } catch (const std::exception& e) {
      status_ = e.what(), split_ = false;
    }
  }
  if (split_) {
    ImGui::SameLine();
    if (ImGui::BeginCombo("right", right_.label().c_str())) {
      for (const MethodInfo& m : registeredMethods())
        if (ImGui::Selectable(m.name.c_str(), &m == right_.info)) {
          try {
            selectRight(methodEntry(m));
          } catch (const std::exception& e) {
            status_ = e.what();
          }
        }
      ImGui::EndCombo();
    }
  }
  int mode = int(display_);
  ImGui::RadioButton("shaded", &mode, 0);
  ImGui::SameLine();
  ImGui::RadioButton("mask", &mode, 1);
  ImGui::SameLine();
  ImGui::RadioButton("diff", &mode, 2);
  display_ = uint32_t(mode);
  if (spec_.animation) {
    ImGui::Checkbox("play", &playing_);
    ImGui::SameLine();
    if (ImGui::Button("step")) playing_ = false, setTime(time_ + (spec_.animation->end - spec_.animation->start) / 100);
    ImGui::SameLine();
    float t = float(time_);
    if (ImGui::SliderFloat("time", &t, float(spec_.animation->start), float(spec_.animation->end))) playing_ = false, setTime(t);
  }
  if (ImGui::BeginCombo("view", camera_.name.c_str())) {
    for (size_t i = 0; i < cameras_.size(); ++i)
      if (ImGui::Selectable(cameras_[i].name.c_str(), i == cameraIndex_)) cameraIndex_ = i, camera_ = cameras_[i], viewChanged();
    ImGui::EndCombo();
  }
  lightPanel();
  ImGui::TextDisabled("H: help");
  ImGui::PopItemWidth();
  ImGui::End();
  // The numbers, in a window of their own at the other corner.
  ImGui::SetNextWindowPos(ImVec2(float(d_.extent.width) - 8, 8), ImGuiCond_Always, ImVec2(1, 0));
  ImGui::SetNextWindowBgAlpha(0.8f);
  ImGui::Begin("numbers", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  const bool wall = !vk_->timestampsTrusted();
  ImGui::Text("frame %.1f ms (%s clock)", lastFrameMs_, wall ? "wall" : "host");
  ImGui::PlotLines("##frames", frameMs_, int(kGraphFrames), int(graphPos_), "frame ms", 0.0f, FLT_MAX, ImVec2(200, 32));
  if (shown_.api) {
    ImGui::Text("record %.2f ms, submit to done %.2f ms, present %.2f ms (wall)", recordMs_, waitMs_, presentMs_);
    ImGui::Text("device memory %.1f MiB", double(api_->deviceBytes()) / (1 << 20));
  } else {
    ImGui::Text("camera pass %.2f ms, method %.2f ms (wall)", rasterMs_, methodMs_);
    for (const StageTime& s : lastOutput_.stages) ImGui::BulletText("%s %.2f ms (%s)", s.name.c_str(), s.ms, stageKindName(s.kind));
    ImGui::Text("allocated %.1f MiB, peak %.1f MiB", double(lastOutput_.bytesAllocated) / (1 << 20),
                double(lastOutput_.peakBytes) / (1 << 20));
  }
  const Counters t = totals();
  ImGui::Text("host cost: %llu submits, %llu presents, %llu allocations", (unsigned long long)t.submits,
              (unsigned long long)t.presents, (unsigned long long)t.allocations);
  ImGui::Text("UI device allocations %llu; heap: ImGui %llu", (unsigned long long)t.uiDeviceAllocations, (unsigned long long)t.uiHeap);
  if (threadHeapAllocations) {
    ImGui::SameLine();
    ImGui::Text(", loop thread's operator new %llu (recordFrame's %llu)", (unsigned long long)t.heap, (unsigned long long)t.apiHeap);
  }
  ImGui::Separator();
  if (errorShown()) {
    ImGui::Text("vs Embree: %llu false shadow, %llu false light outside the band", (unsigned long long)error_.falseShadowOutsideBand,
                (unsigned long long)error_.falseLightOutsideBand);
    ImGui::Text("error outside band %.4f%%, band share %.3f%%%s", 100 * error_.misclassifiedFractionOutsideBand,
                100 * error_.bandFraction, error_.undecided ? " (undecided)" : "");
    ImGui::Text("Embree %.1f ms + band %.1f ms (worker thread)", reference_.referenceMs, reference_.bandMs);
  } else {
    ImGui::TextUnformatted(reference_.failure.empty() ? "Embree reference: when the view comes to rest"
                                                      : ("Embree reference failed: " + reference_.failure).c_str());
  }
  if (!shown_.error.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", shown_.error.c_str());
  if (!status_.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", status_.c_str());
  ImGui::End();
  if (help_) {
    ImGui::SetNextWindowPos(ImVec2(float(d_.extent.width) / 2, float(d_.extent.height) / 2), ImGuiCond_Always, ImVec2(0.5f, 0.5f));
    ImGui::Begin("help", &help_, ImGuiWindowFlags_AlwaysAutoResize);
    ImGui::TextUnformatted(
        "left drag: orbit    shift + left drag: move the light    wheel: dolly\n"
        "W A S D Q E: fly    Tab: next method    1 2 3: shaded, mask, diff\n"
        "P: screenshot (PNG + results row)    R: reset view and light\n"
        "V: split screen    Space: play / pause    .: step (animated scenes)\n"
        "U: hide the panels    H or F1: this help");
    ImGui::End();
  }
}

// A registry method on the frame the camera pass of raster/ drew this frame (registryGBuffer_, host_).
void Viewer::runRegistryMethod(Shown& shown, std::vector<float>& mask, vk::Buffer& vis, MethodOutput& out) {
  if (!shown.method) {
    std::fill(mask.begin(), mask.end(), 1.0f);
  } else {
    const FrameInput input = frameInputOf(spec_.scene, host_, registryGBuffer_, *vk_, light_, policy_.eps, &camera_,
                                          &raster_->deviceScene());
    const auto t0 = Clock::now();
    try {
      out = runCounted(*shown.method, input);
      std::copy(out.visibility.begin(), out.visibility.end(), mask.begin());
    } catch (const std::exception& e) {
      shown.error = e.what();
      shown.method.reset();
      std::fill(mask.begin(), mask.end(), 1.0f);
    }
    if (&shown == &shown_) methodMs_ = msSince(t0);
  }
  std::memcpy(vis.mapped, mask.data(), mask.size() * sizeof(float));
}

void Viewer::recordFrame(VkCommandBuffer cb, uint32_t image) {
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(cb, &bi));
  const uint32_t w = spec_.width, h = spec_.height;
  auto barrier = [&](VkPipelineStageFlags src, VkAccessFlags srcAccess, VkPipelineStageFlags dst, VkAccessFlags dstAccess) {
    VkMemoryBarrier m{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    m.srcAccessMask = srcAccess;
    m.dstAccessMask = dstAccess;
    vkCmdPipelineBarrier(cb, src, dst, 0, 1, &m, 0, nullptr, 0, nullptr);
  };
  if (shown_.api || (split_ && right_.api)) {
    if (!visibilityInitialised_) {  // the visibility image, once, into the GENERAL layout the API takes
      VkImageMemoryBarrier ib{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
      ib.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
      ib.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
      ib.newLayout = VK_IMAGE_LAYOUT_GENERAL;
      ib.srcQueueFamilyIndex = ib.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
      ib.image = visibility_;
      ib.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
      vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 1, &ib);
      visibilityInitialised_ = true;
    }
    // The camera pass.
    RasterPush push{};
    push.viewProj = viewProjection(camera_, float(w) / float(h));
    push.eye = glm::vec4(camera_.eye, 1.0f);
    push.light = glm::vec4(light_, 1.0f);
    VkClearValue clears[3]{};
    clears[2].depthStencil = {1.0f, 0};
    VkRenderPassBeginInfo rb{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    rb.renderPass = gbufferPass_;
    rb.framebuffer = gbufferFb_;
    rb.renderArea = {{0, 0}, {w, h}};
    rb.clearValueCount = 3;
    rb.pClearValues = clears;
    vkCmdBeginRenderPass(cb, &rb, VK_SUBPASS_CONTENTS_INLINE);
    recordCameraDraw(cb, gbufferPipeline_, gbufferLayout_, geometry_, push, w, h);
    vkCmdEndRenderPass(cb);
    // The shadows, through the public API.
    coneshadow::FrameDesc f;
    f.commandBuffer = cb;
    f.frame = frame_;
    f.positionImage = position_.image;
    f.normalImage = normal_.image;
    f.width = w;
    f.height = h;
    f.lights = &lightXyz_[0];
    f.lightCount = uint32_t(active_.size());
    f.visibilityImage = visibility_;
    const uint64_t heapBefore = heapNow();
    api_->recordFrame(f);
    mine_.apiHeap += heapNow() - heapBefore;
    barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, f.lightCount};  // the layers one after another
    region.imageExtent = {w, h, 1};
    if (shown_.api) vkCmdCopyImageToBuffer(cb, visibility_, VK_IMAGE_LAYOUT_GENERAL, visBuf_.buffer, 1, &region);
    if (split_ && right_.api) vkCmdCopyImageToBuffer(cb, visibility_, VK_IMAGE_LAYOUT_GENERAL, visBuf2_.buffer, 1, &region);
    region.imageSubresource.layerCount = 1;
    vkCmdCopyImageToBuffer(cb, position_.image, VK_IMAGE_LAYOUT_GENERAL, posBuf_.buffer, 1, &region);
    vkCmdCopyImageToBuffer(cb, normal_.image, VK_IMAGE_LAYOUT_GENERAL, nrmBuf_.buffer, 1, &region);
    barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
            VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_HOST_READ_BIT);
  }

  // The composite and the panels, into the window's image.
  VkClearValue clear{};
  VkRenderPassBeginInfo rb{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  rb.renderPass = displayPass_;
  rb.framebuffer = displayFbs_[image];
  rb.renderArea = {{0, 0}, d_.extent};
  rb.clearValueCount = 1;
  rb.pClearValues = &clear;
  vkCmdBeginRenderPass(cb, &rb, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, compositePipeline_);
  VkViewport viewport{0, 0, float(d_.extent.width), float(d_.extent.height), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, d_.extent};
  vkCmdSetViewport(cb, 0, 1, &viewport);
  vkCmdSetScissor(cb, 0, 1, &scissor);
  CompositePush push{};
  push.width = w;
  push.height = h;
  push.offsetX = (int(d_.extent.width) - int(w)) / 2;
  push.offsetY = (int(d_.extent.height) - int(h)) / 2;
  push.mode = display_;
  push.reference = reference_.generation == viewGeneration_ && reference_.failure.empty() ? 1u : 0u;
  push.maskGrey = kNotLitMaskGrey;
  push.pad0 = push.pad1 = 0;
  push.background = rgb(kBackgroundRgb);
  push.falseShadow = rgb(kFalseShadowRgb);
  push.falseLight = rgb(kFalseLightRgb);
  push.bandDisagree = rgb(kBandDisagreeRgb);
  // One method over the whole window, or the split screen: the left method left of the frame's middle.
  auto composite = [&](const Shown& shown, const vk::Buffer& vis, VkRect2D area) {
    vkCmdSetScissor(cb, 0, 1, &area);
    const bool api = shown.api;
    // The API's frame: every light shown, a layer each; a registry method's: the focus light's one layer.
    push.lightCount = api ? uint32_t(active_.size()) : 1u;
    push.focusLight = api ? focus_ : 0u;
    push.firstLight = api ? 0u : kMaxLights;
    const VkBuffer bufs[6] = {api ? posBuf_.buffer : registryGBuffer_.position.buffer,
                              api ? nrmBuf_.buffer : registryGBuffer_.normal.buffer, vis.buffer, refBuf_.buffer,
                              bandBuf_.buffer, lightBuf_.buffer};
    VkDescriptorBufferInfo infos[6];
    VkWriteDescriptorSet writes[6];
    for (uint32_t i = 0; i < 6; ++i) {
      infos[i] = {bufs[i], 0, VK_WHOLE_SIZE};
      writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      writes[i].dstBinding = i;
      writes[i].descriptorCount = 1;
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    }
    vk_->cmdPushDescriptorSet(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, compositeLayout_, 0, 6, writes);
    vkCmdPushConstants(cb, compositeLayout_, VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
    vkCmdDraw(cb, 3, 1, 0, 0);
  };
  const int32_t middle = std::clamp(push.offsetX + int32_t(w / 2), 0, int32_t(d_.extent.width));
  if (!split_) {
    composite(shown_, visBuf_, scissor);
  } else {
    composite(shown_, visBuf_, {{0, 0}, {uint32_t(middle), d_.extent.height}});
    composite(right_, visBuf2_, {{middle, 0}, {d_.extent.width - uint32_t(middle), d_.extent.height}});
    VkClearAttachment line{VK_IMAGE_ASPECT_COLOR_BIT, 0, {}};
    line.clearValue.color = {{1.0f, 1.0f, 1.0f, 1.0f}};
    VkClearRect rect{{{std::max(middle - 1, 0), 0}, {2, d_.extent.height}}, 0, 1};
    vkCmdClearAttachments(cb, 1, &line, 1, &rect);
    vkCmdSetScissor(cb, 0, 1, &scissor);
  }
  if (!hideUi_) ImGui_ImplVulkan_RenderDrawData(ImGui::GetDrawData(), cb);
  vkCmdEndRenderPass(cb);

  if (!capturePath_.empty()) {  // the window's image, copied out in the same submission
    VkImageMemoryBarrier ib{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    ib.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    ib.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    ib.oldLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    ib.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    ib.srcQueueFamilyIndex = ib.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    ib.image = d_.images[image];
    ib.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                         nullptr, 1, &ib);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {d_.extent.width, d_.extent.height, 1};
    vkCmdCopyImageToBuffer(cb, d_.images[image], VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, captureBuf_.buffer, 1, &region);
    std::swap(ib.oldLayout, ib.newLayout);
    ib.srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    ib.dstAccessMask = 0;
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0, nullptr, 1, &ib);
    barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
  }
  VK_CHECK(vkEndCommandBuffer(cb));
}

// After the frame's fence: the screenshot, the host snapshot for the reference and the error.
// The loop waits for every frame, so the last one has completed; its times are there when the cone path
// recorded it and the queue family has valid timestamps (coneshadow::FrameStats).
void Viewer::printConeGpuTimes() const {
  if (frame_ == 0) return;
  const coneshadow::FrameStats st = api_->frameStats(frame_ - 1);
  if (!st.available) return;
  if (!st.gpuTimes) {
    std::cout << "view stats: the cone path's GPU times: none (this queue family has no valid timestamps)\n";
    return;
  }
  std::cout << "view stats: the cone path's GPU time, last frame (timestamps; adjacent stages may trade time on "
               "lavapipe): " << st.gpuMs << " ms";
  for (size_t l = 0; l < st.lights.size(); ++l) {
    std::cout << (l ? "; " : ". ") << "light " << l << ":";
    for (uint32_t s = 0; s < coneshadow::kStageCount; ++s)
      std::cout << (s ? ", " : " ") << coneshadow::stageName(coneshadow::Stage(s)) << " " << st.lights[l].stageMs[s];
    std::cout << " ms";
  }
  std::cout << "\n";
}

void Viewer::afterFrame() {
  if (captureInFlight_) {
    frameEvent_ = true;
    writeScreenshot(capturePath_);
    capturePath_.clear();
    captureInFlight_ = false;
  }
  if (needSnapshot_) {
    if (shown_.api) {  // the registry path's camera pass already read its G-buffer and mask back
      std::memcpy(host_.position.data(), posBuf_.mapped, host_.position.size() * sizeof(glm::vec4));
      std::memcpy(host_.normal.data(), nrmBuf_.mapped, host_.normal.size() * sizeof(glm::vec4));
      std::memcpy(hostMask_.data(), static_cast<const float*>(visBuf_.mapped) + size_t(focus_) * hostMask_.size(),
                  hostMask_.size() * sizeof(float));
    }
    needSnapshot_ = false;
    frameEvent_ = true;
    if (worker_->busyWith() != snapshotGeneration_ && reference_.generation != snapshotGeneration_)
      worker_->submit({snapshotGeneration_, std::make_shared<const Scene>(spec_.scene), host_, camera_, light_});  // copies
    if (reference_.generation == snapshotGeneration_) updateError();
  }
}

void Viewer::updateError() {
  errorValid_ = false;
  if (!reference_.failure.empty() || reference_.generation != snapshotGeneration_ || snapshotGeneration_ != viewGeneration_ ||
      snapshotMethodGeneration_ != methodGeneration_)
    return;
  error_ = compareVisibility(host_, hostMask_, reference_.visibility, reference_.band);
  errorValid_ = true;
  errorView_ = viewGeneration_;
  errorMethod_ = methodGeneration_;
}

Counters Viewer::totals() const {
  Counters c = mine_;
  const vk::HostCost a = vk_->cost, b = coneshadow::ContextAccess::vulkan(*api_).cost;
  c.submits += a.submits + b.submits;
  c.hostSyncs += a.hostSyncs + b.hostSyncs;
  c.allocations += a.allocations + b.allocations;
  c.uiDeviceAllocations = uiDeviceAllocations;
  c.uiHeap = uiHeapAllocations;
  c.heap = heapNow();
  return c;
}

void Viewer::writeScreenshot(const std::string& path) {
  const uint32_t w = d_.extent.width, h = d_.extent.height;
  std::vector<uint8_t> out(size_t(w) * h * 3);
  const uint8_t* px = static_cast<const uint8_t*>(captureBuf_.mapped);
  const bool bgra = d_.format == VK_FORMAT_B8G8R8A8_UNORM;
  for (size_t i = 0; i < size_t(w) * h; ++i)
    for (int c = 0; c < 3; ++c) out[3 * i + c] = px[4 * i + (bgra ? 2 - c : c)];
  writePng(path, w, h, out);
  // The frame's results row, as `render` writes them, with where it comes from.
  MethodOutput o = shown_.api ? MethodOutput{} : lastOutput_;
  o.visibility.clear();
  if (shown_.api) {
    o.stages = {{"frame", waitMs_, StageKind::PerFrame}};
    o.totalMs = waitMs_;
    o.bytesAllocated = o.peakBytes = api_->deviceBytes();
  }
  const bool referenceShown = errorShown();
  FrameResult row = makeFrameResult(spec_.scene.name, camera_.name, shown_.label(), host_, vk_->driverDescription(), o,
                                    referenceShown ? error_ : ErrorStats{});
  row.stats["clock"] = vk_->timestampsTrusted() ? "host" : "wall";
  row.stats["reference_shown"] = referenceShown;
  row.stats["display"] = kDisplayNames[display_];
  row.stats["settings"] = shown_.settings.values();
  nlohmann::json lightsShown = nlohmann::json::array();
  for (uint32_t e : active_) lightsShown.push_back({table_[e].x, table_[e].y, table_[e].z});
  row.provenance = {{"tool", "coneshadow view"},
                    {"command_line", spec_.commandLine},
                    {"light", {light_.x, light_.y, light_.z}},
                    {"lights_shown", lightsShown},
                    {"mask_light", focus_},
                    {"camera", {{"eye", {camera_.eye.x, camera_.eye.y, camera_.eye.z}},
                                {"target", {camera_.target.x, camera_.target.y, camera_.target.z}},
                                {"yfov", camera_.yfov}}}};
  const std::string json = (std::filesystem::path(path).replace_extension(".json")).string();
  writeFileAtomic(json, toJson(row).dump(2) + "\n");
  status_ = "wrote " + path;
}

int Viewer::run() {
  steadyMs_.reserve(spec_.frames ? spec_.frames : 100000);
  idleMs_.reserve(steadyMs_.capacity());
  while (!glfwWindowShouldClose(d_.window) && !quit_) {
    const auto frameStart = Clock::now();
    lastFrameMs_ = std::chrono::duration<double, std::milli>(frameStart - lastFrameStart_).count();
    lastFrameStart_ = frameStart;
    frameMs_[graphPos_] = float(lastFrameMs_);
    graphPos_ = (graphPos_ + 1) % kGraphFrames;
    glfwPollEvents();
    const Counters before = totals();
    const bool workerIdleBefore = worker_->busyWith() == 0;
    const uint64_t viewBefore = viewGeneration_, methodBefore = methodGeneration_;

    frameEvent_ = false;
    if (std::optional<ReferenceAnswer> a = worker_->take()) {
      frameEvent_ = true;
      reference_ = std::move(*a);
      if (reference_.failure.empty() && reference_.generation == viewGeneration_) {
        std::memcpy(refBuf_.mapped, reference_.visibility.data(), reference_.visibility.size() * sizeof(float));
        uint32_t* band = static_cast<uint32_t*>(bandBuf_.mapped);
        for (size_t i = 0; i < reference_.band.size(); ++i) band[i] = reference_.band[i];
        updateError();
      }
    }
    applyScript();
    if (playing_) setTime(time_ + lastFrameMs_ / 1000.0);  // scene seconds at the wall clock's pace
    ImGui_ImplVulkan_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    if (!hideUi_) drawUi();
    if (!hideUi_ && frame_ < warmUpFrames()) reserveUiBuffers();
    handleInput();
    ImGui::Render();
    if (viewGeneration_ == viewBefore) ++restFrames_;
    // The lights of the frame: the API's list, the composite's buffer (the frame before is done with it).
    syncLight();
    for (size_t k = 0; k < active_.size(); ++k) {
      frameLights_[k] = glm::vec4(table_[active_[k]], 1.0f);
      for (int c = 0; c < 3; ++c) lightXyz_[3 * k + c] = table_[active_[k]][c];
    }
    frameLights_[kMaxLights] = glm::vec4(light_, 1.0f);
    std::memcpy(lightBuf_.mapped, frameLights_.data(), sizeof(frameLights_));

    if (!shown_.api || (split_ && !right_.api)) {  // the registry's frame: the camera pass of raster/, read back
      const auto t0 = Clock::now();
      raster_->render(camera_, light_, spec_.width, spec_.height, registryGBuffer_, &host_);
      rasterMs_ = msSince(t0);
    }
    if (!shown_.api) runRegistryMethod(shown_, hostMask_, visBuf_, lastOutput_);
    if (split_ && !right_.api) runRegistryMethod(right_, hostMask2_, visBuf2_, rightOutput_);

    uint32_t image = 0;
    const auto acquireStart = Clock::now();
    VkResult acquired = vkAcquireNextImageKHR(d_.device, d_.swapchain, UINT64_MAX, imageReady_, VK_NULL_HANDLE, &image);
    if (acquired == VK_ERROR_OUT_OF_DATE_KHR) {
      destroyFramebuffers();
      createSwapchain(d_);
      createFramebuffers();
      continue;
    }
    if (acquired != VK_SUBOPTIMAL_KHR) VK_CHECK(acquired);
    acquireMs_ = msSince(acquireStart);
    const auto recordStart = Clock::now();
    const bool scriptDone = scriptPos_ >= script_.size() && scriptWait_ == 0 && !scriptWaitReference_;
    const bool last = spec_.frames && frame_ + 1 >= spec_.frames && scriptDone;
    if (last && !spec_.screenshot.empty()) capturePath_ = spec_.screenshot;
    recordFrame(cmd_, image);
    recordMs_ = msSince(recordStart);
    captureInFlight_ = !capturePath_.empty();
    // At rest: the frame goes to the host once for its (view, method), for the reference and the error.
    const bool wantReference = reference_.generation != viewGeneration_ && worker_->busyWith() != viewGeneration_;
    const bool wantError = reference_.generation == viewGeneration_ && !errorShown();
    if (restFrames_ >= kRestFrames && (wantReference || wantError) &&
        !(snapshotGeneration_ == viewGeneration_ && snapshotMethodGeneration_ == methodGeneration_))
      needSnapshot_ = true, snapshotGeneration_ = viewGeneration_, snapshotMethodGeneration_ = methodGeneration_;

    const VkPipelineStageFlags waitStage = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.waitSemaphoreCount = 1;
    si.pWaitSemaphores = &imageReady_;
    si.pWaitDstStageMask = &waitStage;
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd_;
    si.signalSemaphoreCount = 1;
    si.pSignalSemaphores = &renderDone_[image];
    const auto submitStart = Clock::now();
    VK_CHECK(vkQueueSubmit(d_.queue, 1, &si, frameDone_));
    ++mine_.submits;
    VkPresentInfoKHR pi{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
    pi.waitSemaphoreCount = 1;
    pi.pWaitSemaphores = &renderDone_[image];
    pi.swapchainCount = 1;
    pi.pSwapchains = &d_.swapchain;
    pi.pImageIndices = &image;
    const auto presentStart = Clock::now();
    const VkResult presented = vkQueuePresentKHR(d_.queue, &pi);
    presentMs_ = msSince(presentStart);
    ++mine_.presents;
    // One frame in flight: the next frame's recording reuses this one's command buffer and images.
    VK_CHECK(vkWaitForFences(d_.device, 1, &frameDone_, VK_TRUE, UINT64_MAX));
    ++mine_.hostSyncs;
    VK_CHECK(vkResetFences(d_.device, 1, &frameDone_));
    waitMs_ = msSince(submitStart);
    afterFrame();
    if (presented == VK_ERROR_OUT_OF_DATE_KHR || presented == VK_SUBOPTIMAL_KHR) {
      destroyFramebuffers();
      createSwapchain(d_);
      createFramebuffers();
    } else {
      VK_CHECK(presented);
    }

    const Counters after = totals();
    // The warm-up: the pipelines and first uploads, and the UI's vertex and index buffers (one set per
    // swapchain image, made the first time the image is drawn).
    if (frame_ >= warmUpFrames() && viewGeneration_ == viewBefore && methodGeneration_ == methodBefore) {
      ++steadyFrames_;
      steady_.submits += after.submits - before.submits;
      steady_.presents += after.presents - before.presents;
      steady_.allocations += after.allocations - before.allocations;
      steady_.uiDeviceAllocations += after.uiDeviceAllocations - before.uiDeviceAllocations;
      steady_.hostSyncs += after.hostSyncs - before.hostSyncs;
      if (!frameEvent_) {
        ++quietFrames_;
        quietApiHeap_ += after.apiHeap - before.apiHeap;
        quietHeap_ += (after.heap - before.heap) - (after.apiHeap - before.apiHeap);
        quietUiHeap_ += after.uiHeap - before.uiHeap;
      }
      sumAcquireMs_ += acquireMs_, sumPresentMs_ += presentMs_, sumWaitMs_ += waitMs_;
      const double ms = msSince(frameStart);
      if (steadyMs_.size() < steadyMs_.capacity()) steadyMs_.push_back(ms);
      // Embree shares the CPU on lavapipe: the frames it did not run beside are the frame's own cost.
      if (workerIdleBefore && worker_->busyWith() == 0 && idleMs_.size() < idleMs_.capacity()) idleMs_.push_back(ms);
    }
    ++frame_;
    if (last) break;
  }
  if (spec_.stats) {
    auto per = [&](uint64_t n) { return steadyFrames_ ? double(n) / double(steadyFrames_) : 0.0; };
    std::cout << "view stats: frames " << frame_ << ", steady " << steadyFrames_ << ", method " << shown_.label()
              << "; per steady frame: submits " << per(steady_.submits) << ", presents " << per(steady_.presents)
              << ", host syncs " << per(steady_.hostSyncs) << ", device allocations " << per(steady_.allocations)
              << " (the project's) + " << per(steady_.uiDeviceAllocations) << " (ImGui's); host allocations over the "
              << quietFrames_ << " that hand nothing to or from the reference worker and write no screenshot: operator new ";
    if (threadHeapAllocations) std::cout << quietHeap_ << " in the viewer + " << quietApiHeap_ << " in coneshadow::Context::recordFrame";
    else std::cout << "not counted";
    std::cout << ", ImGui " << quietUiHeap_ << "; lights " << active_.size() << "; median frame " << (steadyMs_.empty() ? 0.0 : median(steadyMs_)) << " ms, "
              << (idleMs_.empty() ? 0.0 : median(idleMs_)) << " ms over the " << idleMs_.size()
              << " with the reference worker idle (wall clock, " << spec_.width << "x" << spec_.height << ", "
              << vk_->deviceName() << "); mean acquire " << (steadyFrames_ ? sumAcquireMs_ / double(steadyFrames_) : 0.0)
              << " ms, submit to done " << (steadyFrames_ ? sumWaitMs_ / double(steadyFrames_) : 0.0) << " ms of which the present call "
              << (steadyFrames_ ? sumPresentMs_ / double(steadyFrames_) : 0.0) << " ms\n";
    printConeGpuTimes();
  }
  return 0;
}

}  // namespace

int runViewer(ViewerSpec spec) {
  Viewer viewer(std::move(spec));
  return viewer.run();
}

}  // namespace cs::viewer
