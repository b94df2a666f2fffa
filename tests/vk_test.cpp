// The Vulkan context: buffers both ways, kernels with push descriptors and what they read from their SPIR-V,
// grid maths, timestamps, errors.
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/binding_kinds.comp.h"
#include "tests/iota.comp.h"
#include "traversal/traversal_layout.h"
#include "traversal/traverse_test.comp.h"
#include "tests/test_context.h"

namespace cs {
namespace {

TEST(Grid, SplitsLargeCountsIntoTwoDimensionsWithinTheLimit) {
  EXPECT_EQ(vk::gridFor(0, 64, 65535).groups(), 0u);
  EXPECT_EQ(vk::gridFor(1, 64, 65535).x, 1u);
  EXPECT_EQ(vk::gridFor(64, 64, 65535).x, 1u);
  EXPECT_EQ(vk::gridFor(65, 64, 65535).x, 2u);
  for (uint64_t count : {uint64_t(65535) * 256, uint64_t(65536) * 256, uint64_t(16) << 20, uint64_t(1) << 30}) {
    vk::Grid g = vk::gridFor(count, 256, 65535);
    EXPECT_LE(g.x, 65535u);
    EXPECT_LE(g.y, 65535u);
    EXPECT_GE(g.groups() * 256, count) << count;
    EXPECT_LT((g.groups() - g.x) * 256, count) << "a whole row of workgroups is idle for " << count;
  }
}

TEST(Context, ReportsTheDeviceAndItsLimits) {
  auto& ctx = test::context();
  EXPECT_FALSE(ctx.deviceName().empty());
  EXPECT_GE(ctx.maxStorageBufferRange(), 1u << 27);
  EXPECT_GE(ctx.subgroupSize, 1u);
  EXPECT_NE(ctx.driverDescription().find("Vulkan 1."), std::string::npos);
  // Robust buffer access is on wherever the device offers it (every conformant Vulkan device does).
  VkPhysicalDeviceFeatures features;
  vkGetPhysicalDeviceFeatures(ctx.physical, &features);
  EXPECT_EQ(ctx.robustBufferAccess, features.robustBufferAccess == VK_TRUE);
  EXPECT_TRUE(ctx.robustBufferAccess) << "Vulkan requires the feature of every device";
}

TEST(Context, UnknownDeviceNameIsAClearError) {
  vk::ContextOptions o;
  o.device = "no-such-gpu-anywhere";
  o.quiet = true;
  try {
    vk::createContext(o);
    FAIL() << "expected cs::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-gpu-anywhere"), std::string::npos) << e.what();
  }
}

TEST(Buffer, RoundTripsThroughDeviceAndHostVisibleMemory) {
  auto& ctx = test::context();
  for (auto mem : {vk::Memory::Device, vk::Memory::HostVisible}) {
    std::vector<uint32_t> data(1000);
    std::iota(data.begin(), data.end(), 7u);
    vk::Buffer b = vk::createBuffer(ctx, data.size() * 4, mem);
    vk::upload(ctx, b, data.data(), data.size() * 4);
    EXPECT_EQ(vk::download<uint32_t>(ctx, b, data.size()), data);
    EXPECT_EQ(vk::download<uint32_t>(ctx, b, 10, 990), std::vector<uint32_t>(data.begin() + 990, data.end()));
  }
}

TEST(Kernel, DispatchesOverATwoDimensionalGridAndTimesIt) {
  auto& ctx = test::context();
  vk::Kernel k = vk::createKernel(ctx, "iota", spv_iota_comp, 2, 8);
  vk::Timer timer = vk::createTimer(ctx);
  for (uint32_t count : {1u, 63u, 64u, 65u, 100003u}) {
    std::vector<uint32_t> src(count);
    std::iota(src.begin(), src.end(), 1u);
    vk::Buffer in = vk::createBuffer(ctx, count * 4), out = vk::createBuffer(ctx, count * 4);
    vk::upload(ctx, in, src.data(), count * 4);
    timer.restart();
    vk::Commands cmd(ctx, &timer);
    struct { uint32_t count, scale; } push{count, 3};
    vk::Grid g = vk::gridFor(count, 64, 40);  // a small per-dimension limit forces the 2-D path
    cmd.mark("start");
    cmd.dispatch(k, {in, out}, push, g.x, g.y);
    cmd.barrier();
    cmd.mark("iota");
    cmd.submit();
    auto got = vk::download<uint32_t>(ctx, out, count);
    for (uint32_t i = 0; i < count; ++i) ASSERT_EQ(got[i], src[i] * 3 + i) << "at " << i << " of " << count;
    auto t = timer.intervals();
    ASSERT_EQ(t.size(), 1u);
    EXPECT_EQ(t[0].first, "iota");
    EXPECT_GE(t[0].second, 0.0);
  }
}

// The host's binding count is checked against the kernel's SPIR-V when the kernel is made, and the
// workgroup shape it declares is read from it.
TEST(Vk, AKernelsBindingsAndPushConstantsAreCheckedAgainstItsSpirv) {
  auto& ctx = test::context();
  const vk::SpirvInterface iface = vk::spirvInterface(spv_iota_comp, sizeof(spv_iota_comp));
  EXPECT_EQ(iface.bindings, (std::map<uint32_t, VkDescriptorType>{{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                                                                   {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}}));
  EXPECT_EQ(iface.localSize[0], 64u);
  EXPECT_EQ(iface.localSize[1], 1u);
  for (uint32_t wrong : {1u, 3u}) {
    try {
      vk::createKernel(ctx, "iota", spv_iota_comp, wrong, 8);
      ADD_FAILURE() << wrong << " bindings accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("iota: the host binds " + std::to_string(wrong) + " buffers"),
                std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(vk::createKernel(ctx, "iota", spv_iota_comp, 2, 8).localSize[0], 64u);
  // The push-constant block's size, from its members' offsets and types: two uints, and a shared-layout
  // struct of vec4s and uints.
  EXPECT_EQ(iface.pushBytes, 8u);
  EXPECT_EQ(vk::spirvInterface(spv_traverse_test_comp, sizeof(spv_traverse_test_comp)).pushBytes,
            uint32_t(sizeof(traversal::TraversePush)));
  for (uint32_t wrong : {4u, 16u}) {
    try {
      vk::createKernel(ctx, "iota", spv_iota_comp, 2, wrong);
      ADD_FAILURE() << wrong << " push bytes accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("iota: the host pushes " + std::to_string(wrong) +
                                           " bytes of constants, the kernel's push-constant block is 8 bytes"),
                std::string::npos) << e.what();
    }
  }
  const uint32_t notSpirv[6] = {1, 2, 3, 4, 5, 6};
  EXPECT_THROW(vk::spirvInterface(notSpirv, sizeof(notSpirv)), Error);
}

// The descriptor type of each binding comes from its declaration in the SPIR-V (no device needed): one
// kernel declaring every kind, the same kernel's storage buffer in SPIR-V 1.0's form, and a project kernel
// that mixes texel, uniform and storage buffers.
TEST(VkSpirv, EveryBindingsDescriptorTypeIsReadFromItsDeclaration) {
  using Types = std::map<uint32_t, VkDescriptorType>;
  const Types kinds = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},       {1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER},
                       {2, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER}, {3, VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER},
                       {4, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},        {5, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE},
                       {6, VK_DESCRIPTOR_TYPE_SAMPLER},              {7, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
                       {8, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER}};
  EXPECT_EQ(vk::spirvInterface(spv_binding_kinds_comp, sizeof(spv_binding_kinds_comp)).bindings, kinds);

  // SPIR-V before 1.3 declares a storage buffer as a Uniform pointer to a BufferBlock struct: the same
  // module rewritten that way (storage class StorageBuffer 12 -> Uniform 2, its struct's Block 2 ->
  // BufferBlock 3) still has a storage buffer at binding 0, beside the uniform buffer at 1.
  std::vector<uint32_t> old(std::begin(spv_binding_kinds_comp), std::end(spv_binding_kinds_comp));
  std::map<uint32_t, uint32_t> pointee;
  uint32_t storageStruct = 0;
  for (size_t at = 5; at < old.size(); at += old[at] >> 16) {
    const uint32_t op = old[at] & 0xFFFF;
    if (op == 32) pointee[old[at + 1]] = old[at + 3];  // OpTypePointer
    if (op == 32 && old[at + 2] == 12) old[at + 2] = 2;
    if (op == 59 && old[at + 3] == 12) storageStruct = pointee[old[at + 1]], old[at + 3] = 2;  // OpVariable
  }
  ASSERT_NE(storageStruct, 0u);
  for (size_t at = 5; at < old.size(); at += old[at] >> 16)
    if ((old[at] & 0xFFFF) == 71 && old[at + 1] == storageStruct && old[at + 2] == 2) old[at + 2] = 3;  // OpDecorate
  EXPECT_EQ(vk::spirvInterface(old.data(), old.size() * 4).bindings, kinds);

  // traversal::Traversal's test kernel: triangles, nodes and input pairs as texels, the state words as a
  // uniform buffer, the world triangles and the tree's sample boxes as texels, the rest storage buffers.
  Types test;
  for (uint32_t b = 0; b < 12; ++b)
    test[b] = b < 3 || b >= 10 ? VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER
                               : b == 9 ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  EXPECT_EQ(vk::spirvInterface(spv_traverse_test_comp, sizeof(spv_traverse_test_comp)).bindings, test);
}

// Commands pushes buffers: a kernel declaring an image, a sampler or a storage texel buffer is refused when
// it is made, naming the binding and its kind.
TEST(Kernel, ABindingOfAKindCommandsCannotPushIsRefusedWhenTheKernelIsMade) {
  try {
    vk::createKernel(test::context(), "binding kinds", spv_binding_kinds_comp, 9, 0);
    ADD_FAILURE() << "a storage texel buffer binding accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("binding kinds: binding 3 is a storage texel buffer; kernels bind storage "
                                         "buffers, uniform buffers and uniform texel buffers only"),
              std::string::npos) << e.what();
  }
}

TEST(Kernel, WrongBindingCountIsAnErrorNotACrash) {
  auto& ctx = test::context();
  vk::Kernel k = vk::createKernel(ctx, "iota", spv_iota_comp, 2, 8);
  vk::Buffer a = vk::createBuffer(ctx, 64);
  vk::Commands cmd(ctx);
  struct { uint32_t count, scale; } push{1, 1};
  EXPECT_THROW(cmd.dispatch(k, {a}, push, 1), Error);
}

}  // namespace
}  // namespace cs

namespace cs {
namespace {

// The guard itself: an invalid call must reach the handler that turns messages into test failures.
TEST(Validation, LayerIsActiveAndReportsAnInvalidCall) {
  auto& ctx = test::context();
  auto saved = ctx.onValidationMessage;
  int seen = 0;
  ctx.onValidationMessage = [&](const std::string&) { ++seen; };
  VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bi.size = 0;  // invalid: size must be greater than 0
  bi.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  VkBuffer b = VK_NULL_HANDLE;
  VkResult r = vkCreateBuffer(ctx.device, &bi, nullptr, &b);
  if (r == VK_SUCCESS && b) vkDestroyBuffer(ctx.device, b, nullptr);
  ctx.onValidationMessage = saved;
  EXPECT_GT(seen, 0) << "VK_LAYER_KHRONOS_validation did not report a zero-sized buffer";
}

}  // namespace
}  // namespace cs

namespace cs {
namespace {

TEST(Kernel, ABindingPastMaxStorageBufferRangeIsRefusedBeforeItIsRecorded) {
  // A storage binding larger than the device's maxStorageBufferRange is undefined on a GPU; the range
  // is refused when the dispatch is recorded, naming the kernel, the binding and both sizes.
  auto& ctx = test::context();
  vk::Kernel k = vk::createKernel(ctx, "iota", spv_iota_comp, 2, 8);
  vk::Buffer a = vk::createBuffer(ctx, 64), b = vk::createBuffer(ctx, 64);
  vk::BufferRange past(a, 0, ctx.maxStorageBufferRange() + 16);
  vk::Commands cmd(ctx);
  struct { uint32_t count, scale; } push{1, 1};
  try {
    cmd.dispatch(k, {past, b}, push, 1, 1);
    FAIL() << "a binding past maxStorageBufferRange was recorded";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("iota: binding 0"), std::string::npos) << what;
    EXPECT_NE(what.find("maxStorageBufferRange"), std::string::npos) << what;
  }
}

TEST(Texels, ABufferPastTheDevicesTexelLimitIsAClearError) {
  // The G-buffer, the sort's pair scratch and the traversal's pairs are read as texels: a buffer holding
  // more 16-byte texels than maxTexelBufferElements is refused with the limit and what to do, not bound.
  auto& ctx = test::context();
  vk::Buffer fits = vk::createBuffer(ctx, 16 * 16), past = vk::createBuffer(ctx, 17 * 16);
  test::TexelLimitForTesting limit(16);
  EXPECT_NE(vk::texels(fits, VK_FORMAT_R32G32B32A32_UINT).view, VkBufferView(VK_NULL_HANDLE));
  try {
    vk::texels(past, VK_FORMAT_R32G32B32A32_UINT);
    FAIL() << "a texel buffer past maxTexelBufferElements was made";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("17 16-byte texels"), std::string::npos) << what;
    EXPECT_NE(what.find("maxTexelBufferElements of 16"), std::string::npos) << what;
  }
}

TEST(Uniforms, ARangePastTheBufferOrTheDevicesLimitOrTheWrongBindingIsAClearError) {
  // The words every invocation reads (the traversal's state) are bound as uniform buffers: a range past
  // the buffer or past maxUniformBufferRange is refused with the sizes, and a uniform range given to a
  // storage binding is refused when the dispatch is recorded, naming the kernel and the binding.
  auto& ctx = test::context();
  vk::Buffer words = vk::createBuffer(ctx, 256);
  const vk::BufferRange r = vk::uniforms(words, 256);
  EXPECT_TRUE(r.uniform);
  EXPECT_EQ(r.range, 256u);
  EXPECT_THROW(vk::uniforms(words, 272), Error) << "past the buffer";
  EXPECT_THROW(vk::uniforms(words, 0), Error) << "empty";
  {
    const uint32_t saved = ctx.properties.limits.maxUniformBufferRange;
    ctx.properties.limits.maxUniformBufferRange = 128;
    try {
      vk::uniforms(words, 256);
      ADD_FAILURE() << "a uniform range past maxUniformBufferRange was made";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("256 bytes"), std::string::npos) << what;
      EXPECT_NE(what.find("maxUniformBufferRange of 128"), std::string::npos) << what;
    }
    ctx.properties.limits.maxUniformBufferRange = saved;
  }
  vk::Kernel k = vk::createKernel(ctx, "iota", spv_iota_comp, 2, 8);
  vk::Buffer b = vk::createBuffer(ctx, 64);
  vk::Commands cmd(ctx);
  struct { uint32_t count, scale; } push{1, 1};
  try {
    cmd.dispatch(k, {r, b}, push, 1, 1);
    FAIL() << "a uniform range was bound to a storage binding";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("iota: binding 0 is a storage buffer"), std::string::npos) << what;
  }
}

TEST(Context, VulkanFailuresNameTheCallTheResultAndWhatToDo) {
  // What a device loss or an exhausted heap turns into wherever VK_CHECK sees it (every Vulkan call).
  auto message = [](VkResult r) {
    try {
      vk::fail(r, "vkQueueSubmit(queue, 1, &si, fence)", "vk/context.cpp", 1);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string lost = message(VK_ERROR_DEVICE_LOST);
  EXPECT_NE(lost.find("vkQueueSubmit"), std::string::npos) << lost;
  EXPECT_NE(lost.find("VK_ERROR_DEVICE_LOST"), std::string::npos) << lost;
  EXPECT_NE(lost.find("--device"), std::string::npos) << lost;
  const std::string oom = message(VK_ERROR_OUT_OF_DEVICE_MEMORY);
  EXPECT_NE(oom.find("VK_ERROR_OUT_OF_DEVICE_MEMORY"), std::string::npos) << oom;
  EXPECT_NE(oom.find("lower the resolution"), std::string::npos) << oom;
  const std::string init = message(VK_ERROR_INITIALIZATION_FAILED);
  EXPECT_NE(init.find("ulimit -v"), std::string::npos) << init;
}

}  // namespace
}  // namespace cs
