// coneshadow in a renderer of its own: this program makes its Vulkan instance and device (the first
// device, a GPU where there is one, lavapipe otherwise), fills a G-buffer of a small scene (a box above a
// floor, ray cast on the host), records the library's frame for two lights into its own command buffer
// between its own copies, submits it itself, and writes the two masks as PNG. Then it checks every lit
// pixel against a double-precision ray cast of its own and prints the count that disagree. For the CLI's
// check (tools/example.sh) it also writes the scene (scene.obj), its samples (samples.txt: x y z nx ny nz
// a line, the pixels with geometry row by row) and its masks at those samples (masks.csv).
//   two_lights <out folder>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <coneshadow/coneshadow.h>
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>

namespace {

struct V3 {
  double x, y, z;
};
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator*(V3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
V3 normalize(V3 a) { return a * (1.0 / std::sqrt(dot(a, a))); }

void check(VkResult r, const char* call) {
  if (r != VK_SUCCESS) throw std::runtime_error(std::string(call) + " failed (VkResult " + std::to_string(int(r)) + ")");
}

// Möller-Trumbore: the ray's t at the triangle, or -1.
double hit(V3 o, V3 d, V3 a, V3 b, V3 c) {
  const V3 e1 = b - a, e2 = c - a, p = cross(d, e2);
  const double det = dot(e1, p);
  if (std::fabs(det) < 1e-300) return -1;
  const V3 s = o - a;
  const double u = dot(s, p) / det;
  if (u < 0 || u > 1) return -1;
  const V3 q = cross(s, e1);
  const double v = dot(d, q) / det;
  if (v < 0 || u + v > 1) return -1;
  return dot(e2, q) / det;
}

struct Scene {
  std::vector<float> positions;
  std::vector<uint32_t> indices;
  V3 vertex(uint32_t t, int k) const {
    const float* p = &positions[3 * indices[3 * t + k]];
    return {p[0], p[1], p[2]};
  }
  size_t triangles() const { return indices.size() / 3; }
  void quad(V3 a, V3 b, V3 c, V3 d) {
    const uint32_t base = uint32_t(positions.size() / 3);
    for (V3 v : {a, b, c, d}) positions.insert(positions.end(), {float(v.x), float(v.y), float(v.z)});
    indices.insert(indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
};

Scene boxOverFloor() {
  Scene s;
  s.quad({-6, 0, -6}, {6, 0, -6}, {6, 0, 6}, {-6, 0, 6});
  // Every coordinate exact in binary, so any reader of scene.obj gets the same floats.
  const double x0 = -1, x1 = 1, y0 = 0.75, y1 = 2.5, z0 = -1, z1 = 1;
  s.quad({x0, y0, z0}, {x1, y0, z0}, {x1, y1, z0}, {x0, y1, z0});
  s.quad({x0, y0, z1}, {x0, y1, z1}, {x1, y1, z1}, {x1, y0, z1});
  s.quad({x0, y0, z0}, {x0, y1, z0}, {x0, y1, z1}, {x0, y0, z1});
  s.quad({x1, y0, z0}, {x1, y0, z1}, {x1, y1, z1}, {x1, y1, z0});
  s.quad({x0, y1, z0}, {x1, y1, z0}, {x1, y1, z1}, {x0, y1, z1});
  s.quad({x0, y0, z0}, {x0, y0, z1}, {x1, y0, z1}, {x1, y0, z0});
  return s;
}

}  // namespace

int main(int argc, char** argv) try {
  const std::string out = argc > 1 ? argv[1] : ".";
  const uint32_t W = 256, H = 192;
  const float lights[6] = {3.0f, 6.0f, 2.0f, -4.0f, 5.0f, -1.5f};

  // ---- the renderer's own Vulkan objects, with what coneshadow needs enabled ----
  const coneshadow::DeviceRequirements req = coneshadow::deviceRequirements();
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.apiVersion = req.apiVersion;
  VkInstanceCreateInfo ii{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ii.pApplicationInfo = &app;
  VkInstance instance;
  check(vkCreateInstance(&ii, nullptr, &instance), "vkCreateInstance");
  uint32_t n = 0;
  vkEnumeratePhysicalDevices(instance, &n, nullptr);
  if (n == 0) throw std::runtime_error("no Vulkan device (install mesa-vulkan-drivers for lavapipe)");
  std::vector<VkPhysicalDevice> devices(n);
  vkEnumeratePhysicalDevices(instance, &n, devices.data());
  VkPhysicalDevice physical = devices[0];
  for (VkPhysicalDevice d : devices) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(d, &p);
    if (p.deviceType == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU) physical = d;
  }
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(physical, &props);
  std::printf("device: %s\n", props.deviceName);
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &n, nullptr);
  std::vector<VkQueueFamilyProperties> families(n);
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &n, families.data());
  uint32_t family = 0;
  while (family < n && !(families[family].queueFlags & VK_QUEUE_COMPUTE_BIT)) ++family;
  VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  f12.shaderBufferInt64Atomics = req.shaderBufferInt64Atomics;
  VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  features.pNext = &f12;
  features.features.shaderInt64 = req.shaderInt64;
  const float priority = 1;
  VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qi.queueFamilyIndex = family;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  di.pNext = &features;
  di.queueCreateInfoCount = 1;
  di.pQueueCreateInfos = &qi;
  di.enabledExtensionCount = uint32_t(req.extensions.size());
  di.ppEnabledExtensionNames = req.extensions.data();
  VkDevice device;
  check(vkCreateDevice(physical, &di, nullptr, &device), "vkCreateDevice");
  VkQueue queue;
  vkGetDeviceQueue(device, family, 0, &queue);

  VkPhysicalDeviceMemoryProperties memory;
  vkGetPhysicalDeviceMemoryProperties(physical, &memory);
  std::vector<VkDeviceMemory> allocations;
  auto allocate = [&](VkMemoryRequirements r, VkMemoryPropertyFlags want) {
    for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
      if ((r.memoryTypeBits & (1u << i)) && (memory.memoryTypes[i].propertyFlags & want) == want) {
        VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
        ai.allocationSize = r.size;
        ai.memoryTypeIndex = i;
        VkDeviceMemory m;
        check(vkAllocateMemory(device, &ai, nullptr, &m), "vkAllocateMemory");
        allocations.push_back(m);
        return m;
      }
    throw std::runtime_error("no suitable memory type");
  };
  auto makeImage = [&](VkFormat format, uint32_t layers) {
    VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.format = format;
    ci.extent = {W, H, 1};
    ci.mipLevels = 1;
    ci.arrayLayers = layers;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    VkImage image;
    check(vkCreateImage(device, &ci, nullptr, &image), "vkCreateImage");
    VkMemoryRequirements r;
    vkGetImageMemoryRequirements(device, image, &r);
    check(vkBindImageMemory(device, image, allocate(r, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT), 0), "vkBindImageMemory");
    return image;
  };
  const VkImage positionImage = makeImage(VK_FORMAT_R32G32B32A32_SFLOAT, 1);
  const VkImage normalImage = makeImage(VK_FORMAT_R32G32B32A32_SFLOAT, 1);
  const VkImage visibilityImage = makeImage(VK_FORMAT_R32_SFLOAT, 2);
  VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bi.size = uint64_t(W) * H * 32;  // positions and normals up, then the two masks down
  bi.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  VkBuffer staging;
  check(vkCreateBuffer(device, &bi, nullptr, &staging), "vkCreateBuffer");
  VkMemoryRequirements sr;
  vkGetBufferMemoryRequirements(device, staging, &sr);
  const VkDeviceMemory stagingMemory =
      allocate(sr, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  check(vkBindBufferMemory(device, staging, stagingMemory, 0), "vkBindBufferMemory");
  float* mapped;
  check(vkMapMemory(device, stagingMemory, 0, bi.size, 0, reinterpret_cast<void**>(&mapped)), "vkMapMemory");

  // ---- the G-buffer: world position (w = 1 on geometry) and the normal turned to the camera ----
  const Scene scene = boxOverFloor();
  const V3 eye{0, 7, 9}, target{0, 0.8, 0};
  const V3 fwd = normalize(target - eye), right = normalize(cross(fwd, {0, 1, 0})), up = cross(right, fwd);
  const double tanHalf = std::tan(0.45);
  float* position = mapped;
  float* normal = mapped + size_t(W) * H * 4;
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x) {
      const double sx = (2 * (x + 0.5) / W - 1) * tanHalf * W / H, sy = (1 - 2 * (y + 0.5) / H) * tanHalf;
      const V3 d = normalize(fwd + right * sx + up * sy);
      double best = 1e300;
      size_t tri = 0;
      for (size_t t = 0; t < scene.triangles(); ++t) {
        const double th = hit(eye, d, scene.vertex(t, 0), scene.vertex(t, 1), scene.vertex(t, 2));
        if (th > 0 && th < best) best = th, tri = t;
      }
      float* p = position + 4 * (size_t(y) * W + x);
      float* nn = normal + 4 * (size_t(y) * W + x);
      std::memset(p, 0, 16);
      std::memset(nn, 0, 16);
      if (best == 1e300) continue;
      const V3 hp = eye + d * best;
      V3 nv = normalize(cross(scene.vertex(tri, 1) - scene.vertex(tri, 0), scene.vertex(tri, 2) - scene.vertex(tri, 0)));
      if (dot(nv, d) > 0) nv = nv * -1.0;
      p[0] = float(hp.x), p[1] = float(hp.y), p[2] = float(hp.z), p[3] = 1;
      nn[0] = float(nv.x), nn[1] = float(nv.y), nn[2] = float(nv.z);
    }

  // ---- coneshadow on this device: the geometry, then one frame for both lights ----
  coneshadow::Options options;
  options.framesInFlight = 1;
  options.maxLights = 2;
  auto shadows = coneshadow::Context::create({instance, physical, device, family, vkGetInstanceProcAddr}, options);
  shadows->createInstance(shadows->createMesh(scene.positions.data(), scene.positions.size() / 3, scene.indices.data(),
                                              scene.indices.size()),
                          coneshadow::kIdentity);

  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.queueFamilyIndex = family;
  VkCommandPool pool;
  check(vkCreateCommandPool(device, &pi, nullptr, &pool), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = pool;
  ai.commandBufferCount = 1;
  VkCommandBuffer cmd;
  check(vkAllocateCommandBuffers(device, &ai, &cmd), "vkAllocateCommandBuffers");
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  VkImageMemoryBarrier toGeneral[3];
  const VkImage images[3] = {positionImage, normalImage, visibilityImage};
  for (int i = 0; i < 3; ++i) {
    toGeneral[i] = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    toGeneral[i].dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    toGeneral[i].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    toGeneral[i].newLayout = VK_IMAGE_LAYOUT_GENERAL;
    toGeneral[i].srcQueueFamilyIndex = toGeneral[i].dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    toGeneral[i].image = images[i];
    toGeneral[i].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, i == 2 ? 2u : 1u};
  }
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr,
                       3, toGeneral);
  VkBufferImageCopy upload{};
  upload.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  upload.imageExtent = {W, H, 1};
  vkCmdCopyBufferToImage(cmd, staging, positionImage, VK_IMAGE_LAYOUT_GENERAL, 1, &upload);
  upload.bufferOffset = uint64_t(W) * H * 16;
  vkCmdCopyBufferToImage(cmd, staging, normalImage, VK_IMAGE_LAYOUT_GENERAL, 1, &upload);
  // The library's barrier contract: the samples written, visible to transfer reads.
  VkMemoryBarrier written{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  written.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  written.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &written, 0, nullptr, 0,
                       nullptr);
  coneshadow::FrameDesc frame;
  frame.commandBuffer = cmd;
  frame.frame = 0;
  frame.positionImage = positionImage;
  frame.normalImage = normalImage;
  frame.width = W;
  frame.height = H;
  frame.lights = lights;
  frame.lightCount = 2;
  frame.visibilityImage = visibilityImage;
  shadows->recordFrame(frame);
  // ...and after it: the masks written by transfers, read by ours.
  written.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &written, 0, nullptr, 0,
                       nullptr);
  VkBufferImageCopy down{};
  down.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 2};
  down.imageExtent = {W, H, 1};
  vkCmdCopyImageToBuffer(cmd, visibilityImage, VK_IMAGE_LAYOUT_GENERAL, staging, 1, &down);
  VkMemoryBarrier toHost{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  toHost.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  toHost.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &toHost, 0, nullptr, 0, nullptr);
  check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
  // The G-buffer is overwritten by the masks: keep the samples for the check.
  const std::vector<float> samples(mapped, mapped + size_t(W) * H * 8);
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd;
  check(vkQueueSubmit(queue, 1, &si, VK_NULL_HANDLE), "vkQueueSubmit");
  check(vkQueueWaitIdle(queue), "vkQueueWaitIdle");
  const coneshadow::FrameStats stats = shadows->frameStats(0);

  // ---- the masks as PNG, and each lit pixel against a double-precision shadow ray ----
  size_t disagree = 0, lit = 0;
  for (uint32_t l = 0; l < 2; ++l) {
    const float* mask = mapped + size_t(l) * W * H;
    std::vector<unsigned char> png(size_t(W) * H);
    const V3 light{lights[3 * l], lights[3 * l + 1], lights[3 * l + 2]};
    for (size_t i = 0; i < size_t(W) * H; ++i) {
      png[i] = static_cast<unsigned char>(std::lround(255 * mask[i]));
      const float* p = &samples[4 * i];
      const float* nn = &samples[size_t(W) * H * 4 + 4 * i];
      const V3 pos{p[0], p[1], p[2]}, to = light - pos;
      if (p[3] != 1 || dot({nn[0], nn[1], nn[2]}, to) <= 0) continue;
      ++lit;
      bool blocked = false;
      for (size_t t = 0; t < scene.triangles() && !blocked; ++t) {
        const double th = hit(pos, to, scene.vertex(t, 0), scene.vertex(t, 1), scene.vertex(t, 2));
        blocked = th > 1e-5 && th < 1 - 1e-5;
      }
      disagree += (mask[i] == 0.0f) != blocked;
    }
    const std::string file = out + "/light" + std::to_string(l) + ".png";
    if (!stbi_write_png(file.c_str(), int(W), int(H), 1, png.data(), int(W)))
      throw std::runtime_error("cannot write " + file);
    std::printf("%s: %u lit pixels, %llu pairs tested%s\n", file.c_str(), stats.lights[l].litSamples,
                (unsigned long long)stats.lights[l].pairsTested, stats.lights[l].complete ? "" : " (incomplete)");
  }
  std::printf("%zu of %zu lit pixels disagree with a double-precision ray cast\n", disagree, lit);
  if (stats.gpuTimes) {  // timestamps in our command buffer; a stage's split from its neighbours may vary by driver
    std::printf("the frame took %.3f ms on the GPU; sort and traversal:", stats.gpuMs);
    for (uint32_t l = 0; l < 2; ++l)
      std::printf(" light %u %.3f and %.3f ms%s", l, stats.lights[l].stageMs[uint32_t(coneshadow::Stage::Sort)],
                  stats.lights[l].stageMs[uint32_t(coneshadow::Stage::Traversal)], l ? "\n" : ",");
  }

  // ---- the same frame as files, for `coneshadow visibility` to answer on its own ----
  std::ofstream obj(out + "/scene.obj"), txt(out + "/samples.txt"), csv(out + "/masks.csv");
  for (size_t v = 0; v < scene.positions.size(); v += 3)
    obj << "v " << scene.positions[v] << " " << scene.positions[v + 1] << " " << scene.positions[v + 2] << "\n";
  for (size_t t = 0; t < scene.triangles(); ++t)
    obj << "f " << scene.indices[3 * t] + 1 << " " << scene.indices[3 * t + 1] + 1 << " " << scene.indices[3 * t + 2] + 1 << "\n";
  csv << "mask_0,mask_1\n";
  char line[200];
  for (size_t i = 0; i < size_t(W) * H; ++i) {
    const float* p = &samples[4 * i];
    const float* nn = &samples[size_t(W) * H * 4 + 4 * i];
    if (p[3] != 1) continue;
    std::snprintf(line, sizeof line, "%.9g %.9g %.9g %.9g %.9g %.9g\n", p[0], p[1], p[2], nn[0], nn[1], nn[2]);
    txt << line;
    csv << (mapped[i] >= 0.5f) << "," << (mapped[size_t(W) * H + i] >= 0.5f) << "\n";
  }
  if (!obj || !txt || !csv) throw std::runtime_error("cannot write the scene, samples or masks into " + out);

  shadows.reset();
  vkDestroyCommandPool(device, pool, nullptr);
  vkDestroyBuffer(device, staging, nullptr);
  for (VkImage image : images) vkDestroyImage(device, image, nullptr);
  for (VkDeviceMemory m : allocations) vkFreeMemory(device, m, nullptr);
  vkDestroyDevice(device, nullptr);
  vkDestroyInstance(instance, nullptr);
  return disagree == 0 ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "two_lights: %s\n", e.what());
  return 1;
}
