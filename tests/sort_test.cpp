// sort/: scan, compaction and radix sort against CPU references over lengths that straddle the block and
// tile sizes; the Hilbert index and ray keys of rays/hilbert.h on both sides of the GLSL/C++ contract;
// the lit samples of a rastered scene in ray order, and how much closer sorted neighbours are.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "core/scene.h"
#include "raster/raster.h"
#include "rays/hilbert.h"
#include "rays/rays.h"
#include "sort/sort.h"
#include "tests/hilbert_grid.comp.h"
#include "tests/test_context.h"

namespace cs {
namespace {

using sort::Count;
using sort::GpuWord;

// Lengths around one element, one scan block (2048) and one sort tile (8192) and their multiples, and one
// past a million; most of them not multiples of 4 (kernels move four elements at a time).
const std::vector<uint32_t> kLengths = {1, 7, 1023, 1025, SCAN_BLOCK - 1, SCAN_BLOCK, SCAN_BLOCK + 1, 2 * SCAN_BLOCK + 1,
                                        SORT_THREADS_GPU * SORT_ITEMS_GPU + 1, SORT_THREADS_CPU * SORT_ITEMS_CPU - 1,
                                        SORT_THREADS_CPU * SORT_ITEMS_CPU, SORT_THREADS_CPU * SORT_ITEMS_CPU + 1, 100003,
                                        (1u << 20) + 3};

std::vector<uint32_t> randomWords(size_t n, uint32_t seed, uint32_t bound = 0) {
  std::mt19937 rng(seed);
  std::vector<uint32_t> v(n);
  for (auto& x : v) x = bound ? rng() % bound : rng();
  return v;
}

vk::Buffer gpuArray(vk::Context& ctx, const std::vector<uint32_t>& data, size_t minElements = 0) {
  vk::Buffer b = vk::createBuffer(ctx, std::max(data.size(), minElements) * 4);
  vk::upload(ctx, b, data.data(), data.size() * 4);
  return b;
}

std::vector<uint32_t> exclusiveSum(const std::vector<uint32_t>& v) {
  std::vector<uint32_t> out(v.size());
  uint32_t sum = 0;
  for (size_t i = 0; i < v.size(); ++i) out[i] = sum, sum += v[i];
  return out;
}

// First index where two arrays differ, or -1: keeps failure output to one line on million-element arrays.
long firstMismatch(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  if (a.size() != b.size()) return 0;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i] != b[i]) return long(i);
  return -1;
}

#define EXPECT_SAME_ARRAY(got, want, what)                                                                   \
  do {                                                                                                       \
    const std::vector<uint32_t>& got_ = (got);                                                               \
    const std::vector<uint32_t>& want_ = (want);                                                             \
    long at_ = firstMismatch(got_, want_);                                                                   \
    EXPECT_EQ(at_, -1) << what << ": first difference at " << at_ << " of " << want_.size() << " (got "      \
                       << (at_ >= 0 && size_t(at_) < got_.size() ? got_[at_] : 0) << ", want "               \
                       << (at_ >= 0 && size_t(at_) < want_.size() ? want_[at_] : 0) << ")";                  \
  } while (0)

// ---- sizing ---------------------------------------------------------------------------------------

TEST(SortSizing, ScanLevelsShrinkByOneBlockUntilOneBlockRemains) {
  auto levels = [](uint32_t n, size_t minLevels = 1) {
    const sort::ScanLevels l = sort::scanLevelCounts(n, minLevels);
    return std::vector<uint32_t>(l.begin(), l.end());
  };
  EXPECT_EQ(levels(0), std::vector<uint32_t>{0});
  EXPECT_EQ(levels(SCAN_BLOCK), std::vector<uint32_t>{SCAN_BLOCK});
  EXPECT_EQ(levels(SCAN_BLOCK + 1), (std::vector<uint32_t>{SCAN_BLOCK + 1, 2}));
  EXPECT_EQ(levels(7, 2), (std::vector<uint32_t>{7, 1}));
  EXPECT_EQ(levels(SCAN_BLOCK * SCAN_BLOCK + 1), (std::vector<uint32_t>{SCAN_BLOCK * SCAN_BLOCK + 1, SCAN_BLOCK + 1, 2}));
  EXPECT_EQ(sort::scanLevelCounts(UINT32_MAX).size(), 3u) << "two levels of block sums cover any 32-bit count";
  EXPECT_EQ(sort::scanScratchElements(100), 2u) << "one sum and its scan";
}

TEST(SortSizing, RadixPassesAndTilesCoverTheKeysAndTheCount) {
  EXPECT_EQ(sort::radixPasses(0), 0u);
  EXPECT_EQ(sort::radixPasses(1), 1u);
  EXPECT_EQ(sort::radixPasses(9), 1u);
  EXPECT_EQ(sort::radixPasses(10), 2u);
  EXPECT_EQ(sort::radixPasses(rays::kRayKeyBits), 2u) << "the ray key, in either frame: two passes";
  EXPECT_EQ(sort::radixPasses(32), 4u);
  for (sort::SortShape shape : {sort::kCpuSortShape, sort::kGpuSortShape}) {
    EXPECT_EQ(sort::sortTiles(0, shape), 0u);
    EXPECT_EQ(sort::sortTiles(shape.tile(), shape), 1u);
    EXPECT_EQ(sort::sortTiles(shape.tile() + 1, shape), 2u);
    EXPECT_EQ(sort::histogramEntries(shape.tile() + 1, shape), 2u * RADIX_BINS);
  }
  EXPECT_EQ(sort::kCpuSortShape.tile(), 8192u);
  EXPECT_LE(sort::radixScatterSharedBytes(sort::kCpuSortShape), 32u * 1024) << "fits lavapipe's shared memory";
  EXPECT_LE(sort::radixScatterSharedBytes(sort::kGpuSortShape), 32u * 1024) << "fits lavapipe's: tested here";
  EXPECT_EQ(sort::kGpuSortShape.tile() * 4, sort::kCpuSortShape.tile());
  EXPECT_LE(sort::radixScatterSharedBytes(), test::context().properties.limits.maxComputeSharedMemorySize);
}

// The tile's shape is the device's: the CPU shape on a CPU device (lavapipe, where it was measured), the
// GPU one elsewhere when the device holds it; a sort made without a shape takes the device's.
TEST(SortSizing, TheTileShapeIsChosenPerDevice) {
  auto& ctx = test::context();
  const sort::SortShape chosen = sort::sortShapeFor(ctx);
  if (ctx.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
    EXPECT_EQ(chosen.threads, sort::kCpuSortShape.threads);
    EXPECT_EQ(chosen.items, sort::kCpuSortShape.items);
  } else if (sort::radixScatterSharedBytes(sort::kGpuSortShape) <= ctx.properties.limits.maxComputeSharedMemorySize) {
    EXPECT_EQ(chosen.threads, sort::kGpuSortShape.threads);
    EXPECT_EQ(chosen.items, sort::kGpuSortShape.items);
  }
  sort::RadixSort sorter(ctx, 1000);
  EXPECT_EQ(sorter.shape().tile(), chosen.tile());
  // The scheme too: look-back on NVIDIA and AMD GPUs; reduce-then-scan on a CPU device (lavapipe ends an
  // invocation's loops after 65535 iterations, which a long look-back walk could pass) and elsewhere.
  const bool lookBackDevice = ctx.properties.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU &&
                              (ctx.properties.vendorID == 0x10DE || ctx.properties.vendorID == 0x1002);
  EXPECT_EQ(sort::sortSchemeFor(ctx), lookBackDevice ? sort::SortScheme::LookBack : sort::SortScheme::ReduceThenScan);
  EXPECT_EQ(sorter.scheme(), sort::sortSchemeFor(ctx));
  // The look-back workspace: counters, every pass's digit totals, and a status row per pass and tile.
  EXPECT_EQ(sort::lookBackWords(sort::kCpuSortShape.tile() + 1, sort::kCpuSortShape),
            uint64_t(LOOKBACK_STATUS) + 4u * 2u * RADIX_BINS);
  // A shape whose packed counters would carry, or that the device cannot hold, is a clear error.
  EXPECT_THROW(sort::RadixSort(ctx, 1000, sort::SortShape{64, 1024}), Error);
  EXPECT_THROW(sort::RadixSort(ctx, 1000, sort::SortShape{4096, 4}), Error);
}

TEST(SortSizing, CountsBeyondOneStorageBindingAreAClearError) {
  auto& ctx = test::context();
  const uint64_t limit = ctx.maxStorageBufferRange();
  if (limit / 4 >= UINT32_MAX) GTEST_SKIP() << "this device binds 2^32 uint32 at once";
  const uint32_t tooMany = uint32_t(limit / 4 + 1);
  try {
    sort::RadixSort sorter(ctx, tooMany);
    FAIL() << "expected cs::Error";
  } catch (const Error& e) {
    std::string what = e.what();
    EXPECT_NE(what.find(std::to_string(tooMany)), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(limit)), std::string::npos) << what;
  }
  EXPECT_THROW(sort::Scan(ctx, tooMany), Error);
  EXPECT_THROW(sort::Compact(ctx, tooMany), Error);
  EXPECT_NO_THROW(sort::checkBinding(ctx, limit / 4, 4, "exactly the limit"));
}

TEST(SortSizing, ScreenDomainCoversTheImageWithWholeMortonTiles) {
  const uint32_t tile = 1u << MORTON_TILE_BITS;
  EXPECT_EQ(rays::screenDomain(1024, 1024, rays::RayOrder::ScreenMorton).size, 1024u * 1024u);
  rays::ScreenDomain d = rays::screenDomain(1920, 1080, rays::RayOrder::ScreenMorton);
  EXPECT_EQ(d.tilesX, 30u);
  EXPECT_EQ(d.tilesY, 17u);
  EXPECT_EQ(d.size, uint64_t(30) * 17 * tile * tile);
  EXPECT_EQ(rays::screenDomain(1920, 1080, rays::RayOrder::Hilbert).size, 1920u * 1080u);
  // Every pixel of an odd-sized image appears exactly once in the Morton enumeration.
  const uint32_t w = 100, h = 70;
  d = rays::screenDomain(w, h, rays::RayOrder::ScreenMorton);
  std::vector<int> seen(w * h, 0);
  for (uint32_t i = 0; i < d.size; ++i) {
    glm::uvec2 p = rays::screenOrderPixel(i, d.tilesX);
    if (p.x < w && p.y < h) seen[p.y * w + p.x]++;
  }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), long(w * h));
  // Four consecutive positions form a 2x2 block.
  for (uint32_t i = 0; i < 64; i += 4) {
    glm::uvec2 a = rays::screenOrderPixel(i, 2), b = rays::screenOrderPixel(i + 3, 2);
    EXPECT_EQ(b - a, glm::uvec2(1, 1)) << i;
    EXPECT_EQ(a % 2u, glm::uvec2(0, 0)) << i;
  }
}

// The Morton enumeration of the tiles that meet a rect (screenDomain with the rect) holds the rect's
// pixels in the image's enumeration order: the same samples in the same order, from fewer positions.
TEST(SortSizing, TheMortonWindowOfARectKeepsItsPixelsInTheImagesOrder) {
  const uint32_t w = 300, h = 200;
  const PixelRect rects[] = {{0, 0, 300, 200}, {70, 20, 130, 150}, {64, 64, 128, 128}, {299, 199, 300, 200},
                             {10, 10, 10, 20}};
  const rays::ScreenDomain whole = rays::screenDomain(w, h, rays::RayOrder::ScreenMorton);
  for (const PixelRect& r : rects) {
    auto inRect = [&](glm::uvec2 p) { return p.x >= r.x0 && p.x < r.x1 && p.y >= r.y0 && p.y < r.y1; };
    std::vector<uint32_t> want, got;
    for (uint32_t i = 0; i < whole.size; ++i)
      if (glm::uvec2 p = rays::screenOrderPixel(i, whole.tilesX); inRect(p)) want.push_back(p.y * w + p.x);
    const rays::ScreenDomain d = rays::screenDomain(w, h, rays::RayOrder::ScreenMorton, r);
    EXPECT_LE(d.size, whole.size);
    const uint32_t first = d.tileX0 | d.tileY0 << 16;
    for (uint32_t i = 0; i < d.size; ++i) {
      const glm::uvec2 p = rays::windowTileOrigin(i, d.tilesX, first) + rays::screenOffsetInTile(i);
      if (inRect(p)) got.push_back(p.y * w + p.x);
    }
    EXPECT_EQ(got, want) << r.x0 << "," << r.y0 << " .. " << r.x1 << "," << r.y1;
  }
  EXPECT_EQ(rays::screenDomain(w, h, rays::RayOrder::ScreenMorton, {70, 20, 130, 150}).size, 2u * 3 * 64 * 64);
}

// ---- scan ---------------------------------------------------------------------------------------

TEST(Scan, MatchesCpuOnEveryLengthForRandomZeroAndOneInputs) {
  auto& ctx = test::context();
  sort::Scan scan(ctx, kLengths.back());
  vk::Buffer total = vk::createBuffer(ctx, 16);
  for (uint32_t n : kLengths) {
    for (int pattern = 0; pattern < 3; ++pattern) {
      std::vector<uint32_t> in = pattern == 0 ? randomWords(n, n) : std::vector<uint32_t>(n, pattern == 1 ? 0u : 1u);
      vk::Buffer a = gpuArray(ctx, in), b = vk::createBuffer(ctx, n * 4);
      vk::Commands cmd(ctx);
      scan.record(cmd, a, b, n, GpuWord(total, 1));
      cmd.submit();
      std::vector<uint32_t> want = exclusiveSum(in);
      EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, b, n), want, "scan of " << n << ", pattern " << pattern);
      EXPECT_EQ(vk::download<uint32_t>(ctx, total, 1, 1)[0], want.back() + in.back()) << n;
    }
  }
}

TEST(Scan, CrossesThreeLevelsInPlace) {
  auto& ctx = test::context();
  const uint32_t n = SCAN_BLOCK * SCAN_BLOCK + 5;  // block sums of block sums
  ASSERT_EQ(sort::scanLevelCounts(n).size(), 3u);
  std::vector<uint32_t> in = randomWords(n, 3, 1000);
  vk::Buffer a = gpuArray(ctx, in), total = vk::createBuffer(ctx, 16);
  sort::Scan scan(ctx, n);
  vk::Commands cmd(ctx);
  scan.record(cmd, a, a, n, GpuWord(total, 0));
  cmd.submit();
  std::vector<uint32_t> want = exclusiveSum(in);
  EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, a, n), want, "in-place scan");
  EXPECT_EQ(vk::download<uint32_t>(ctx, total, 1)[0], want.back() + in.back());
}

TEST(Scan, ReadsItsCountFromTheGpuAndLeavesTheRestAlone) {
  auto& ctx = test::context();
  const uint32_t bound = 50000;
  std::vector<uint32_t> in = randomWords(bound, 9, 100);
  sort::Scan scan(ctx, bound);
  for (uint32_t n : {0u, 1u, 2048u, 2049u, 33333u, bound}) {
    vk::Buffer a = gpuArray(ctx, in), b = gpuArray(ctx, std::vector<uint32_t>(bound, 0xABCDu));
    vk::Buffer words = gpuArray(ctx, {0, 0, n, 0});  // the count at element 2, the total at 3
    vk::Commands cmd(ctx);
    scan.record(cmd, a, b, Count::device(GpuWord(words, 2), bound), GpuWord(words, 3));
    cmd.submit();
    std::vector<uint32_t> want = exclusiveSum(std::vector<uint32_t>(in.begin(), in.begin() + n));
    want.resize(bound, 0xABCDu);
    EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, b, bound), want, "device count " << n);
    EXPECT_EQ(vk::download<uint32_t>(ctx, words, 1, 3)[0], std::accumulate(in.begin(), in.begin() + n, 0u));
  }
}

// A field of packed words (rays/: a run's pixel in the low bits, its length less one above bit 27) scanned
// as the lengths, with the count on the GPU and the first level's workgroups from it (Count::withGroups):
// the words past the count, and the workgroups past its blocks, change nothing.
TEST(Scan, CountsAFieldOfPackedWordsWithItsWorkgroupsFromTheDevice) {
  auto& ctx = test::context();
  const uint32_t bound = 3 * SCAN_BLOCK * SCAN_BLOCK / 2 + 7, shift = 27;  // three levels at the bound
  std::mt19937 rng(5);
  std::vector<uint32_t> in(bound), lengths(bound);
  for (uint32_t i = 0; i < bound; ++i) {
    lengths[i] = 1 + rng() % 32;
    in[i] = (rng() & ((1u << shift) - 1u)) | ((lengths[i] - 1u) << shift);
  }
  sort::Scan scan(ctx, bound);
  sort::IndirectGroups groups(ctx);
  vk::Buffer args = vk::createBuffer(ctx, 16, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  for (uint32_t n : {0u, 1u, 2047u, 2048u, 2049u, 300001u, bound}) {
    vk::Buffer a = gpuArray(ctx, in), b = gpuArray(ctx, std::vector<uint32_t>(bound, 0xABCDu));
    vk::Buffer words = gpuArray(ctx, {0, 0, n, 0});  // the count at element 2, the total at 3
    const Count count = Count::device(GpuWord(words, 2), bound);
    vk::Commands cmd(ctx);
    groups.record(cmd, count, SCAN_BLOCK, args, 0);
    cmd.barrier();
    scan.record(cmd, a, b, count.withGroups(args.buffer, 0), GpuWord(words, 3), int(shift));
    cmd.submit();
    std::vector<uint32_t> want = exclusiveSum(std::vector<uint32_t>(lengths.begin(), lengths.begin() + n));
    want.resize(bound, 0xABCDu);
    EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, b, bound), want, "device count " << n);
    EXPECT_EQ(vk::download<uint32_t>(ctx, words, 1, 3)[0], std::accumulate(lengths.begin(), lengths.begin() + n, 0u));
  }
}

TEST(Scan, WorksOnRangesInsideABufferAndRejectsMisalignedOnes) {
  auto& ctx = test::context();
  const uint32_t n = 5001, first = 64;  // the array starts 256 bytes into the buffer
  std::vector<uint32_t> data = randomWords(first + n + 8, 4, 50);
  vk::Buffer buf = gpuArray(ctx, data), out = vk::createBuffer(ctx, (n + 32) * 4);
  sort::Scan scan(ctx, n);
  vk::Commands cmd(ctx);
  scan.record(cmd, vk::BufferRange(buf, first * 4, n * 4), vk::BufferRange(out, 64, n * 4), n);
  cmd.submit();
  std::vector<uint32_t> want = exclusiveSum(std::vector<uint32_t>(data.begin() + first, data.begin() + first + n));
  EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, out, n, 16), want, "scan of a sub-range");
  EXPECT_EQ(vk::download<uint32_t>(ctx, buf, data.size()), data) << "the input is untouched";
  EXPECT_THROW(scan.record(cmd, vk::BufferRange(buf, 4, n * 4), out, n), Error);
  EXPECT_THROW(scan.record(cmd, buf, vk::BufferRange(buf, 8, n * 4), n), Error) << "partly overlapping";
}

// ---- compaction ---------------------------------------------------------------------------------

TEST(Compact, MatchesCpuOnEveryLengthForRandomZeroAndOneFlags) {
  auto& ctx = test::context();
  sort::Compact compact(ctx, kLengths.back());
  vk::Buffer kept = vk::createBuffer(ctx, 16);
  for (uint32_t n : kLengths) {
    for (int pattern = 0; pattern < 3; ++pattern) {
      std::vector<uint32_t> flags = pattern == 0 ? randomWords(n, n + 1, 3) : std::vector<uint32_t>(n, pattern == 1 ? 0u : 7u);
      std::vector<uint32_t> want;
      for (uint32_t i = 0; i < n; ++i)
        if (flags[i]) want.push_back(i);
      vk::Buffer f = gpuArray(ctx, flags), out = vk::createBuffer(ctx, n * 4);
      vk::Commands cmd(ctx);
      compact.record(cmd, f, n, out, GpuWord(kept, 0));
      cmd.submit();
      uint32_t count = vk::download<uint32_t>(ctx, kept, 1)[0];
      ASSERT_EQ(count, want.size()) << "kept of " << n << ", pattern " << pattern;
      EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, out, count), want, "compaction of " << n << ", pattern " << pattern);
    }
  }
}

TEST(Compact, CarriesValuesAndReadsItsCountFromTheGpu) {
  auto& ctx = test::context();
  const uint32_t bound = 70001;
  std::vector<uint32_t> flags = randomWords(bound, 5, 2), values = randomWords(bound, 6);
  sort::Compact compact(ctx, bound);
  vk::Buffer f = gpuArray(ctx, flags), v = gpuArray(ctx, values), out = vk::createBuffer(ctx, bound * 4);
  for (uint32_t n : {0u, 5u, 4096u, 65537u}) {
    vk::Buffer words = gpuArray(ctx, {n, 0xFFFFFFFFu});
    vk::Commands cmd(ctx);
    compact.record(cmd, f, Count::device(GpuWord(words, 0), bound), out, GpuWord(words, 1), v);
    cmd.submit();
    std::vector<uint32_t> want;
    for (uint32_t i = 0; i < n; ++i)
      if (flags[i]) want.push_back(values[i]);
    uint32_t count = vk::download<uint32_t>(ctx, words, 1, 1)[0];
    ASSERT_EQ(count, want.size()) << n;
    EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, out, count), want, "values kept of " << n);
  }
}

// ---- radix sort ---------------------------------------------------------------------------------

struct Pairs {
  std::vector<uint32_t> keys, values;
};

// The reference: std::stable_sort by the low `keyBits` bits of the key.
Pairs stableSorted(const Pairs& in, uint32_t keyBits = 32) {
  const uint32_t mask = keyBits >= 32 ? ~0u : (1u << keyBits) - 1u;
  std::vector<uint32_t> order(in.keys.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return (in.keys[a] & mask) < (in.keys[b] & mask); });
  Pairs out;
  for (uint32_t i : order) out.keys.push_back(in.keys[i]), out.values.push_back(in.values[i]);
  return out;
}

Pairs gpuSorted(sort::RadixSort& sorter, const Pairs& in, uint32_t keyBits = 32) {
  auto& ctx = test::context();
  const uint32_t n = uint32_t(in.keys.size());
  vk::Buffer k = gpuArray(ctx, in.keys), v = gpuArray(ctx, in.values);
  vk::Commands cmd(ctx);
  sorter.record(cmd, k, v, n, keyBits);
  cmd.submit();
  return {vk::download<uint32_t>(ctx, k, n), vk::download<uint32_t>(ctx, v, n)};
}

// Values are the input positions, so equal keys must come out with increasing values.
Pairs withPositions(std::vector<uint32_t> keys) {
  Pairs p{std::move(keys), {}};
  p.values.resize(p.keys.size());
  std::iota(p.values.begin(), p.values.end(), 0u);
  return p;
}

// Every test below runs with both tile shapes and both schemes on whatever device runs the tests, so the
// shape and the scheme a GPU gets are proven on lavapipe too.
struct SortSetup {
  sort::SortShape shape;
  sort::SortScheme scheme;
};
class RadixSortShapes : public testing::TestWithParam<SortSetup> {
 protected:
  sort::RadixSort makeSorter(uint32_t capacity) {
    return sort::RadixSort(test::context(), capacity, GetParam().shape, GetParam().scheme);
  }
};
INSTANTIATE_TEST_SUITE_P(Shapes, RadixSortShapes,
                         testing::Values(SortSetup{sort::kCpuSortShape, sort::SortScheme::ReduceThenScan},
                                         SortSetup{sort::kGpuSortShape, sort::SortScheme::ReduceThenScan},
                                         SortSetup{sort::kCpuSortShape, sort::SortScheme::LookBack},
                                         SortSetup{sort::kGpuSortShape, sort::SortScheme::LookBack}),
                         [](const testing::TestParamInfo<SortSetup>& p) {
                           return std::to_string(p.param.shape.threads) + "x" + std::to_string(p.param.shape.items) +
                                  (p.param.scheme == sort::SortScheme::LookBack ? "_LookBack" : "_ReduceThenScan");
                         });

TEST_P(RadixSortShapes, MatchesStableSortOnRandomKeysOfEveryLength) {
  sort::RadixSort sorter = makeSorter(kLengths.back());
  for (uint32_t n : kLengths) {
    Pairs in = withPositions(randomWords(n, 100 + n));
    Pairs want = stableSorted(in), got = gpuSorted(sorter, in);
    EXPECT_SAME_ARRAY(got.keys, want.keys, "keys of " << n);
    EXPECT_SAME_ARRAY(got.values, want.values, "values of " << n);
  }
}

TEST_P(RadixSortShapes, MatchesStableSortOnSortedReversedAndAllEqualKeys) {
  const uint32_t n = 300007;
  sort::RadixSort sorter = makeSorter(n);
  std::vector<uint32_t> sorted = randomWords(n, 11);
  std::sort(sorted.begin(), sorted.end());
  std::vector<uint32_t> reversed(sorted.rbegin(), sorted.rend());
  for (auto* keys : {&sorted, &reversed}) {
    Pairs in = withPositions(*keys);
    Pairs want = stableSorted(in), got = gpuSorted(sorter, in);
    EXPECT_SAME_ARRAY(got.keys, want.keys, (keys == &sorted ? "sorted" : "reversed") << " keys");
    EXPECT_SAME_ARRAY(got.values, want.values, (keys == &sorted ? "sorted" : "reversed") << " values");
  }
  for (uint32_t key : {0u, 0x80000001u, 0xFFFFFFFFu}) {
    Pairs in = withPositions(std::vector<uint32_t>(n, key));
    Pairs got = gpuSorted(sorter, in);
    EXPECT_SAME_ARRAY(got.keys, in.keys, "all-equal keys " << key);
    EXPECT_SAME_ARRAY(got.values, in.values, "all-equal keys keep their order, key " << key);
  }
}

TEST_P(RadixSortShapes, IsStableOnFewDistinctKeys) {
  const uint32_t n = (1u << 20) + 3;
  sort::RadixSort sorter = makeSorter(n);
  for (uint32_t distinct : {2u, 3u, 17u}) {
    std::vector<uint32_t> keys = randomWords(n, distinct, distinct);
    for (auto& k : keys) k *= 0x01010101u;  // the same digit in every byte: every pass moves them
    Pairs in = withPositions(keys);
    Pairs want = stableSorted(in), got = gpuSorted(sorter, in);
    EXPECT_SAME_ARRAY(got.keys, want.keys, distinct << " distinct keys");
    EXPECT_SAME_ARRAY(got.values, want.values, "equal keys keep their input order, " << distinct << " distinct");
  }
}

TEST_P(RadixSortShapes, SortsOnlyTheRequestedKeyBitsInOddAndEvenPassCounts) {
  const uint32_t n = 123457;
  sort::RadixSort sorter = makeSorter(n);
  Pairs in = withPositions(randomWords(n, 77));
  for (uint32_t bits : {1u, 7u, 8u, 12u, 24u, 31u}) {
    Pairs want = stableSorted(in, bits), got = gpuSorted(sorter, in, bits);
    EXPECT_SAME_ARRAY(got.keys, want.keys, bits << " key bits (" << sort::radixPasses(bits) << " passes)");
    EXPECT_SAME_ARRAY(got.values, want.values, bits << " key bits");
  }
}

TEST_P(RadixSortShapes, SortsKeysAloneUpToACountReadFromTheGpu) {
  auto& ctx = test::context();
  const uint32_t bound = 90000;
  std::vector<uint32_t> keys = randomWords(bound, 8);
  sort::RadixSort sorter = makeSorter(bound);
  // Larger counts before smaller ones: the indirect passes launch only the tiles a count fills, and the
  // histogram entries a larger count left in the others must not reach the scan.
  for (uint32_t n : {0u, 1u, 2049u, 77777u, 2049u, 1u, 0u, 90000u}) {
    vk::Buffer k = gpuArray(ctx, keys), words = gpuArray(ctx, {0, n});
    vk::Commands cmd(ctx);
    sorter.record(cmd, k, vk::BufferRange(), Count::device(GpuWord(words, 1), bound));
    cmd.submit();
    std::vector<uint32_t> want = keys;
    std::sort(want.begin(), want.begin() + n);
    EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, k, bound), want, "device count " << n);
  }
}

// Between passes the pairs travel interleaved in the sort's scratch, or as two arrays where pairs would
// not fit one binding: both give the stable sort, for every pass count, with a count read from the GPU.
TEST_P(RadixSortShapes, CarriesValuesAlikeThroughPairedOrSeparateScratch) {
  struct Restore {
    ~Restore() { sort::setPairScratchForTesting(-1); }
  } restore;
  auto& ctx = test::context();
  const uint32_t bound = 70001;
  Pairs in = withPositions(randomWords(bound, 19));
  for (int32_t paired : {1, 0}) {
    sort::setPairScratchForTesting(paired);
    sort::RadixSort sorter = makeSorter(bound);
    for (uint32_t bits : {8u, 20u, 31u})
      for (uint32_t n : {0u, 3u, 4099u, 70001u}) {
        vk::Buffer k = gpuArray(ctx, in.keys), v = gpuArray(ctx, in.values), words = gpuArray(ctx, {n});
        vk::Commands cmd(ctx);
        sorter.record(cmd, k, v, Count::device(GpuWord(words, 0), bound), bits);
        cmd.submit();
        Pairs head{{in.keys.begin(), in.keys.begin() + n}, {in.values.begin(), in.values.begin() + n}};
        Pairs want = stableSorted(head, bits);
        want.keys.insert(want.keys.end(), in.keys.begin() + n, in.keys.end());
        want.values.insert(want.values.end(), in.values.begin() + n, in.values.end());
        const char* how = paired ? "paired scratch" : "separate scratch";
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, k, bound), want.keys, how << ", " << bits << " bits, count " << n);
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, v, bound), want.values, how << ", " << bits << " bits, count " << n);
      }
  }
}

// A producer that writes its pairs straight into the sort's scratch (RadixSort::recordFromPairs, as the
// cone path's fused compaction does) gets the stable sort, for two, three and four passes, a host count
// or one read from the GPU below the capacity; only the pairs below the count are read. Asked for the
// order only (keysOut false), the values are the same and the keys' array is left untouched.
TEST_P(RadixSortShapes, SortsPairsWrittenIntoItsOwnScratch) {
  auto& ctx = test::context();
  const uint32_t capacity = 70001;
  sort::RadixSort sorter = makeSorter(capacity);
  ASSERT_TRUE(sorter.pairInputs());
  for (uint32_t bits : {18u, 27u, 32u})
    for (uint32_t n : {1u, 4097u, 70001u})
      for (bool deviceCount : {false, true})
      for (bool keysOut : {true, false}) {
        Pairs in = withPositions(randomWords(capacity, 7 * n + bits));
        std::vector<uint32_t> interleaved;
        for (uint32_t i = 0; i < capacity; ++i) interleaved.push_back(in.keys[i]), interleaved.push_back(in.values[i]);
        const std::vector<uint32_t> untouched(capacity, 0xDEADBEEFu);
        vk::Buffer k = gpuArray(ctx, untouched), v = vk::createBuffer(ctx, capacity * 4);
        vk::Buffer word = gpuArray(ctx, {0, n});
        vk::Buffer produced = gpuArray(ctx, interleaved);  // as a producer's kernel would write them
        const vk::BufferRange input = sorter.pairInput();
        ASSERT_GE(input.range, produced.size);
        vk::Commands cmd(ctx);
        const VkBufferCopy region{0, input.offset, produced.size};
        vkCmdCopyBuffer(cmd.handle(), produced.buffer, input.buffer, 1, &region);
        cmd.barrier();
        sorter.recordFromPairs(cmd, k, v, deviceCount ? sort::Count::device(GpuWord(word, 1), capacity) : sort::Count(n), bits,
                               keysOut);
        cmd.submit();
        in.keys.resize(n), in.values.resize(n);
        const Pairs want = stableSorted(in, bits);
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, k, n), keysOut ? want.keys : std::vector<uint32_t>(n, 0xDEADBEEFu),
                          bits << " bits, count " << n << (deviceCount ? " (GPU)" : "") << (keysOut ? "" : ", order only"));
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, v, n), want.values, bits << " bits, count " << n);
      }
  vk::Buffer k = vk::createBuffer(ctx, 64), v = vk::createBuffer(ctx, 64);
  vk::Commands cmd(ctx);
  EXPECT_THROW(sorter.recordFromPairs(cmd, k, v, 16, 9), Error) << "one pass has no pair scratch to start from";
}

// The look-back never depends on how long another tile takes: a tile still unpublished after a few reads
// is counted from its keys by the one waiting. With no read at all, every tile before is counted (the
// walk never meets a published prefix); with one, any wait takes that path; the sort is the stable one.
// Pair scratch is read as texels: a capacity whose pairs would pass the device's texel limit keeps
// separate arrays, and sorts the same.
TEST(RadixSortShapes, PairsPastTheTexelLimitFallBackToSeparateArrays) {
  const uint32_t n = 5003;
  test::TexelLimitForTesting limit(n / 4);  // two pairs a texel: n pairs do not fit
  sort::RadixSort sorter(test::context(), n);
  Pairs in = withPositions(randomWords(n, 41));
  for (uint32_t bits : {9u, 27u}) {
    Pairs want = stableSorted(in, bits), got = gpuSorted(sorter, in, bits);
    EXPECT_SAME_ARRAY(got.keys, want.keys, bits << " key bits");
    EXPECT_SAME_ARRAY(got.values, want.values, bits << " key bits");
  }
}

TEST(RadixSortLookBack, CountingAnUnpublishedTileItselfGivesTheSameSort) {
  struct Restore {
    ~Restore() { sort::setLookBackSpinsForTesting(-1); }
  } restore;
  for (auto [spins, n] : {std::pair{0, 20011u}, std::pair{1, 300007u}}) {
    sort::setLookBackSpinsForTesting(spins);
    for (sort::SortShape shape : {sort::kCpuSortShape, sort::kGpuSortShape}) {
      sort::RadixSort sorter(test::context(), n, shape, sort::SortScheme::LookBack);
      for (uint32_t bits : {1u, 8u, 31u}) {
        Pairs in = withPositions(randomWords(n, 5 + bits));
        Pairs want = stableSorted(in, bits), got = gpuSorted(sorter, in, bits);
        EXPECT_SAME_ARRAY(got.keys, want.keys, bits << " key bits, tile " << shape.tile() << ", " << spins << " reads");
        EXPECT_SAME_ARRAY(got.values, want.values, bits << " key bits, tile " << shape.tile() << ", " << spins << " reads");
      }
    }
  }
}

// The indirect grid for a device count is the one vk::gridFor makes on the host for the same count
// (clamped to the bound), 2-D past the device's workgroups per dimension, and zero workgroups for zero.
TEST(IndirectGroups, WriteTheHostsGridForTheDeviceCount) {
  auto& ctx = test::context();
  sort::IndirectGroups groups(ctx);
  const uint32_t maxPerDim = std::min(ctx.properties.limits.maxComputeWorkGroupCount[0],
                                      ctx.properties.limits.maxComputeWorkGroupCount[1]);
  const uint32_t beyond = 3 * maxPerDim + 7;  // items of one per workgroup: a 2-D grid
  struct Case {
    uint32_t count, bound, perGroup;
  };
  for (const Case c : {Case{0, 100, 64}, Case{1, 100, 64}, Case{64, 100, 64}, Case{65, 100, 64}, Case{500, 100, 64},
                       Case{beyond, beyond, 1}, Case{beyond, 2 * maxPerDim, 1}}) {
    vk::Buffer words = gpuArray(ctx, {7, c.count}), args = gpuArray(ctx, std::vector<uint32_t>(8, 99));
    vk::Commands cmd(ctx);
    groups.record(cmd, Count::device(GpuWord(words, 1), c.bound), c.perGroup, args, 2);
    cmd.barrier();
    cmd.submit();
    const std::vector<uint32_t> got = vk::download<uint32_t>(ctx, args, 8);
    const vk::Grid want = vk::gridFor(std::min(c.count, c.bound), c.perGroup, maxPerDim);
    EXPECT_EQ(got[2], want.x) << c.count << " of at most " << c.bound;
    EXPECT_EQ(got[3], want.y) << c.count;
    EXPECT_EQ(got[4], 1u);
    EXPECT_EQ(got[1], 99u) << "words before the arguments stay";
    EXPECT_EQ(got[5], 99u) << "words after them stay";
  }
  // At least minGroups workgroups (the radix sort's one tile for an empty count), more where the count needs them.
  for (const uint32_t count : {0u, 1u, 200u}) {
    vk::Buffer words = gpuArray(ctx, {count}), args = gpuArray(ctx, std::vector<uint32_t>(4, 99));
    vk::Commands cmd(ctx);
    groups.record(cmd, Count::device(GpuWord(words, 0), 1000), 64, args, 0, 2);
    cmd.barrier();
    cmd.submit();
    const std::vector<uint32_t> got = vk::download<uint32_t>(ctx, args, 4);
    EXPECT_EQ(got[0], std::max(2u, (count + 63) / 64)) << count;
    EXPECT_EQ(got[1], 1u) << count;
  }
}

// ---- Hilbert index and ray keys -----------------------------------------------------------------

// The GPU's hilbertIndex over every cell of a 2^order grid, and its rayKey of each direction.
std::vector<uint32_t> gpuHilbert(uint32_t order, const std::vector<glm::vec4>& dirs, std::vector<uint32_t>* rayKeys) {
  auto& ctx = test::context();
  const uint32_t cells = 1u << (2 * order);
  vk::Kernel k = vk::createKernel(ctx, "hilbert_grid", spv_hilbert_grid_comp, 3, sizeof(rays::HilbertGridPush));
  vk::Buffer out = vk::createBuffer(ctx, cells * 4), d = vk::createBuffer(ctx, std::max<size_t>(dirs.size(), 1) * 16);
  vk::Buffer keys = vk::createBuffer(ctx, std::max<size_t>(dirs.size(), 1) * 4);
  vk::upload(ctx, d, dirs.data(), dirs.size() * 16);
  rays::HilbertGridPush push{order, uint32_t(dirs.size())};
  vk::Grid g = vk::gridFor(std::max<size_t>(cells, dirs.size()), PIXEL_THREADS, ctx.maxWorkgroups());
  vk::Commands cmd(ctx);
  cmd.dispatch(k, {out, d, keys}, push, g.x, g.y);
  cmd.barrier();
  cmd.submit();
  if (rayKeys) *rayKeys = vk::download<uint32_t>(ctx, keys, dirs.size());
  return vk::download<uint32_t>(ctx, out, cells);
}

// An independent CPU reference: the textbook xy2d (quadrant rotation over the full grid side n).
uint32_t referenceHilbert(uint32_t n, uint32_t x, uint32_t y) {
  uint32_t d = 0;
  for (uint32_t s = n / 2; s > 0; s /= 2) {
    uint32_t rx = (x & s) > 0, ry = (y & s) > 0;
    d += s * s * ((3 * rx) ^ ry);
    if (ry == 0) {
      if (rx == 1) x = n - 1 - x, y = n - 1 - y;
      std::swap(x, y);
    }
  }
  return d;
}

TEST(Hilbert, GpuAndCpuMatchAnIndependentReferenceOnEveryCellOfSmallGrids) {
  for (uint32_t order = 1; order <= 8; ++order) {
    std::vector<uint32_t> gpu = gpuHilbert(order, {}, nullptr), cpu, want;
    const uint32_t side = 1u << order;
    for (uint32_t i = 0; i < side * side; ++i) {
      cpu.push_back(rays::hilbertIndex(i % side, i / side, order));
      want.push_back(referenceHilbert(side, i % side, i / side));
    }
    EXPECT_SAME_ARRAY(gpu, want, "GPU, order " << order);
    EXPECT_SAME_ARRAY(cpu, want, "CPU, order " << order);
  }
  // On the CPU, every cell up to 2^12 x 2^12 (the ray key's grids go to 2^9), and samples of the far
  // frame's (2^15) and the largest (2^16).
  for (uint32_t order = 9; order <= 12u; ++order) {
    const uint32_t side = 1u << order;
    for (uint32_t y = 0; y < side; ++y)
      for (uint32_t x = 0; x < side; ++x)
        if (rays::hilbertIndex(x, y, order) != referenceHilbert(side, x, y))
          FAIL() << "order " << order << ", cell " << x << "," << y;
  }
  std::mt19937 rng(5);
  for (uint32_t order : {13u, 14u, 15u, 16u}) {
    const uint32_t side = 1u << order;
    for (int i = 0; i < 200000; ++i) {
      uint32_t x = rng() % side, y = rng() % side;
      ASSERT_EQ(rays::hilbertIndex(x, y, order), referenceHilbert(side, x, y)) << "order " << order << ", " << x << "," << y;
    }
  }
}

TEST(Hilbert, ConsecutiveIndicesAreNeighbouringCells) {
  for (uint32_t order = 1; order <= 10; ++order) {
    const uint32_t side = 1u << order;
    std::vector<glm::ivec2> cellOf(side * side, glm::ivec2(-1));
    for (uint32_t y = 0; y < side; ++y)
      for (uint32_t x = 0; x < side; ++x) {
        uint32_t d = rays::hilbertIndex(x, y, order);
        ASSERT_LT(d, side * side);
        ASSERT_EQ(cellOf[d], glm::ivec2(-1)) << "index " << d << " used twice at order " << order;
        cellOf[d] = glm::ivec2(x, y);
      }
    EXPECT_EQ(cellOf.front(), glm::ivec2(0, 0)) << "the curve starts at the origin";
    EXPECT_EQ(cellOf.back(), glm::ivec2(side - 1, 0)) << "and ends at the last column";
    for (uint32_t d = 1; d < side * side; ++d) {
      glm::ivec2 step = glm::abs(cellOf[d] - cellOf[d - 1]);
      ASSERT_EQ(step.x + step.y, 1) << "order " << order << ": index " << d - 1 << " -> " << d;
    }
  }
}

// The slots rayKey gives the faces (every face counted alike).
glm::uvec2 wholeFaceSlot(uint32_t face) {
  uint32_t same[6] = {1, 1, 1, 1, 1, 1};
  return rays::faceKeySlot(face, same);
}
// The face whose run of keys (under rayKey's slots) holds `key`; 7 for none.
uint32_t wholeFaceKeyFace(uint32_t key) {
  for (uint32_t face = 0; face < 6; ++face) {
    const glm::uvec2 s = wholeFaceSlot(face);
    if (key >= s.y && key - s.y < (1u << (2 * s.x))) return face;
  }
  return 7;
}

// Whether `got` is the ray key of d on `keyGrid` (its face's, faceKeyGrid; default rayKey's: the whole
// face) with each face coordinate (d[axis+1] / |d[axis]|, d[axis+2] / ...) moved by up to `ulps` ulp: what
// a GPU may give, since Vulkan lets its division be 2.5 ulp off (a direction that close to a cell edge may
// land in the neighbouring cell). The face must be exact: it comes from comparisons alone.
bool isRayKeyUpToDivision(glm::vec3 d, uint32_t got, std::optional<glm::vec4> keyGrid = {}, int ulps = 3) {
  const uint32_t face = rays::rayFace(d);
  if (face == 7) return got == RAY_KEY_DEGENERATE;
  const glm::vec4 gr = keyGrid ? *keyGrid : rays::faceKeyGrid(glm::uvec4(RAY_BOUNDS_EMPTY), wholeFaceSlot(face));
  const uint32_t want = rays::faceKey(d, face, gr);
  if (got == want) return true;
  const uint32_t slot = uint32_t(gr.w), order = slot & 15u, first = slot >> 4;
  if (order == 0 || got < first || got - first >= (1u << (2 * order))) return false;
  const uint32_t axis = face >> 1;
  const float m = std::abs(d[axis]), last = float((1u << order) - 1);
  auto cells = [&](float q, float lo0, float scale) {  // the range of cells q moved by up to `ulps` ulp falls in
    float lo = q, hi = q;
    for (int i = 0; i < ulps; ++i) lo = std::nextafter(lo, -INFINITY), hi = std::nextafter(hi, INFINITY);
    auto cell = [&](float x) { return uint32_t(std::clamp(std::floor((x - lo0) * scale), 0.0f, last)); };
    return glm::uvec2(cell(lo), cell(hi));
  };
  const glm::uvec2 xs = cells(d[(axis + 1) % 3] / m, gr.x, gr.z), ys = cells(d[(axis + 2) % 3] / m, gr.y, gr.z);
  for (uint32_t x = xs.x; x <= xs.y; ++x)
    for (uint32_t y = ys.x; y <= ys.y; ++y)
      if (std::min(first + rays::hilbertIndex(x, y, order), rays::kRayKeyLast) == got) return true;
  return false;
}

TEST(RayKeys, FaceIsTheMajorAxisWithTiesGoingToTheLowestAxis) {
  using glm::vec3;
  EXPECT_EQ(rays::rayFace(vec3(2, 1, -1)), 0u);
  EXPECT_EQ(rays::rayFace(vec3(-2, 1, 1)), 1u);
  EXPECT_EQ(rays::rayFace(vec3(0.5f, 3, 1)), 2u);
  EXPECT_EQ(rays::rayFace(vec3(0.5f, -3, 1)), 3u);
  EXPECT_EQ(rays::rayFace(vec3(0, 0, 1e-30f)), 4u);
  EXPECT_EQ(rays::rayFace(vec3(0, 0, -5)), 5u);
  EXPECT_EQ(rays::rayFace(vec3(1, 1, 0)), 0u) << "x == y: x";
  EXPECT_EQ(rays::rayFace(vec3(-1, 1, 1)), 1u) << "x == y == z: x, negative";
  EXPECT_EQ(rays::rayFace(vec3(0, -2, 2)), 3u) << "y == z: y";
  EXPECT_EQ(rays::rayFace(vec3(-0.0f, -0.0f, 0)), 7u) << "zero length";
  // Face corners and edges land on the grid's corners and edges; the centre on the middle cells.
  const uint32_t order = RAY_KEY_MAX_ORDER, last = (1u << order) - 1, mid = 1u << (order - 1);
  EXPECT_EQ(rays::rayCell(vec3(1, -1, -1), 0, order), glm::uvec2(0, 0));
  EXPECT_EQ(rays::rayCell(vec3(1, 1, 1), 0, order), glm::uvec2(last, last));
  EXPECT_EQ(rays::rayCell(vec3(1, 0, 0), 0, order), glm::uvec2(mid, mid));
  EXPECT_EQ(rays::rayCell(vec3(-4, 4, -4), 1, order), glm::uvec2(last, 0)) << "-x face: (y, z) / 4";
  EXPECT_EQ(wholeFaceKeyFace(rays::rayKey(vec3(1, -1, -1))), 0u);
  EXPECT_EQ(wholeFaceKeyFace(rays::rayKey(vec3(0, 0, -1))), 5u);
  // Scaling a direction does not move it.
  EXPECT_EQ(rays::rayKey(vec3(0.3f, -0.2f, 0.9f)), rays::rayKey(vec3(3, -2, 9) * 0.25f * 0.4f));
}

TEST(RayKeys, ZeroLengthAndNonFiniteRaysGetTheDegenerateKeyOnBothSides) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<glm::vec4> dirs = {{0, 0, 0, 0}, {-0.0f, 0, -0.0f, 0}, {inf, 0, 0, 0}, {1, -inf, 0, 0}, {nan, 1, 1, 0}, {1, 1, nan, 0}};
  std::vector<uint32_t> gpu;
  gpuHilbert(1, dirs, &gpu);
  for (size_t i = 0; i < dirs.size(); ++i) {
    EXPECT_EQ(rays::rayKey(glm::vec3(dirs[i])), rays::kRayKeyDegenerate) << "direction " << i;
    EXPECT_EQ(gpu[i], rays::kRayKeyDegenerate) << "direction " << i;
  }
  // Greater than every real direction's key: degenerate rays sort last (faceKeySlots below: a real key
  // is at most RAY_KEY_LAST).
  EXPECT_EQ(rays::kRayKeyDegenerate, (1u << rays::kRayKeyBits) - 1);
  EXPECT_EQ(rays::kRayKeyLast, rays::kRayKeyDegenerate - 1);
  for (float a : {1.0f, -1.0f})
    for (float b : {0.999f, -0.999f})
      for (float c : {0.999f, -0.999f}) {
        EXPECT_LT(rays::rayKey(glm::vec3(a, b, c)), rays::kRayKeyDegenerate);
        EXPECT_LT(rays::rayKey(glm::vec3(b, a, c)), rays::kRayKeyDegenerate);
        EXPECT_LT(rays::rayKey(glm::vec3(c, b, a)), rays::kRayKeyDegenerate);
      }
}

// The key space shared out among the faces by the subset's counts: runs that do not overlap, in face
// order, the finest for the faces with the most samples, each face reached at least 2^7 x 2^7 cells.
TEST(RayKeys, FaceSlotsShareOutTheKeySpaceByTheSubsetsCounts) {
  auto slots = [](std::array<uint32_t, 6> counts) {
    std::array<glm::uvec2, 6> s;
    for (uint32_t face = 0; face < 6; ++face) s[face] = rays::faceKeySlot(face, counts.data());
    return s;
  };
  using glm::uvec2;
  const uint32_t last = rays::kRayKeyLast;
  std::array<glm::uvec2, 6> s = slots({0, 0, 0, 0, 900, 0});
  EXPECT_EQ(s[4], uvec2(9, 0)) << "one face: 2^9 x 2^9 cells, the whole key space";
  for (uint32_t face : {0u, 1u, 2u, 3u, 5u}) EXPECT_EQ(s[face], uvec2(0, last)) << "face " << face << ": not reached";
  // Its last cell, the curve's end (2^9 - 1, 0), shares the key of the cell before it: degenerate rays
  // stay last.
  const glm::vec4 grid = rays::faceKeyGrid(glm::uvec4(RAY_BOUNDS_EMPTY), s[4]);
  EXPECT_EQ(rays::faceKey(glm::vec3(0.9999f, -0.9999f, 1), 4, grid), last);
  EXPECT_EQ(rays::faceKey(glm::vec3(-0.9999f, -0.9999f, 1), 4, grid), 0u) << "the curve's start";
  EXPECT_EQ(rays::faceKey(glm::vec3(5, 5, 0.1f), 0, rays::faceKeyGrid(glm::uvec4(RAY_BOUNDS_EMPTY), s[0])), last)
      << "a face the subset missed";
  s = slots({3, 0, 7, 0, 0, 0});
  EXPECT_EQ(s[0], uvec2(8, 0)) << "two faces: 2^8 each, in face order";
  EXPECT_EQ(s[2], uvec2(8, 1u << 16));
  s = slots({5, 5, 5, 5, 0, 0});
  EXPECT_EQ(s[0], uvec2(8, 0)) << "four faces of 2^8: ties to the lower face";
  EXPECT_EQ(s[3], uvec2(8, 3u << 16));
  s = slots({1, 9, 2, 8, 3, 7});
  uint32_t next = 0;
  for (uint32_t face = 0; face < 6; ++face) {
    EXPECT_EQ(s[face].y, next) << "face " << face << ": runs in face order, back to back";
    EXPECT_EQ(s[face].x, face == 1 || face == 3 || face == 5 ? 8u : 7u) << "face " << face;
    next += 1u << (2 * s[face].x);
  }
  EXPECT_LE(next, 1u << rays::kRayKeyBits);
  // Every count pattern: runs disjoint, inside the key space, at least 2^7 for each face reached.
  for (uint32_t mask = 1; mask < 64; ++mask)
    for (uint32_t seed = 0; seed < 8; ++seed) {
      std::array<uint32_t, 6> counts{};
      for (uint32_t face = 0; face < 6; ++face) counts[face] = (mask >> face & 1) ? 1 + (face * 7 + seed * 3) % 5 : 0;
      s = slots(counts);
      std::vector<std::pair<uint32_t, uint32_t>> runs;
      for (uint32_t face = 0; face < 6; ++face) {
        if (counts[face] == 0) {
          EXPECT_EQ(s[face], uvec2(0, last));
          continue;
        }
        EXPECT_GE(s[face].x, uint32_t(RAY_KEY_MIN_ORDER));
        EXPECT_LE(s[face].x, uint32_t(RAY_KEY_MAX_ORDER));
        runs.push_back({s[face].y, s[face].y + (1u << (2 * s[face].x))});
      }
      std::sort(runs.begin(), runs.end());
      for (size_t i = 1; i < runs.size(); ++i) EXPECT_LE(runs[i - 1].second, runs[i].first) << "mask " << mask;
      EXPECT_LE(runs.back().second, 1u << rays::kRayKeyBits) << "mask " << mask;
    }
}

TEST(RayKeys, GpuMatchesCpuOnRandomAndFaceBoundaryDirections) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<glm::vec4> dirs;
  for (int i = 0; i < 200000; ++i) dirs.push_back({u(rng), u(rng), u(rng), 0});
  for (float a : {1.0f, -1.0f})  // exact ties between axes and exact cell edges
    for (float b : {1.0f, -1.0f, 0.5f, 0.0f, -0.25f})
      for (float c : {1.0f, -1.0f, 0.0f, 0.125f}) {
        dirs.push_back({a, b, c, 0});
        dirs.push_back({b, a, c, 0});
        dirs.push_back({c, b, a, 0});
      }
  std::vector<uint32_t> gpu;
  gpuHilbert(1, dirs, &gpu);
  size_t differ = 0;
  for (size_t i = 0; i < dirs.size(); ++i) {
    const glm::vec3 d(dirs[i]);
    ASSERT_EQ(wholeFaceKeyFace(gpu[i]), wholeFaceKeyFace(rays::rayKey(d))) << "face of direction " << i;
    ASSERT_TRUE(isRayKeyUpToDivision(d, gpu[i]))
        << "direction " << i << " (" << d.x << ", " << d.y << ", " << d.z << "): key " << gpu[i] << ", want "
        << rays::rayKey(d) << " or a neighbouring cell's";
    differ += gpu[i] != rays::rayKey(d);
  }
  std::printf("ray keys: %zu of %zu differ from the CPU's by a division's rounding\n", differ, dirs.size());
  // Lavapipe divides exactly, so there the keys are identical.
  if (test::context().properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
    EXPECT_EQ(differ, 0u);
  }
}

// ---- lit samples in ray order -------------------------------------------------------------------

struct Frame {
  uint32_t width, height;
  GBuffer host;
  DeviceGBuffer device;
  glm::vec3 light;
};

// A hand-made sample's normal for `light`: facing it squarely when `lit`, facing away otherwise; w the
// light term as the G-buffer holds it (the kernels compute it from the light, core/shared.h
// litSampleFor, and never read w; the CPU references read w). A sample at the light is never lit.
glm::vec4 normalFor(glm::vec3 position, glm::vec3 light, bool lit) {
  const glm::vec3 toLight = light - position;
  if (glm::length(toLight) == 0.0f) return glm::vec4(0, 1, 0, 0);
  const glm::vec3 n = glm::normalize(toLight) * (lit ? 1.0f : -1.0f);
  return glm::vec4(n, lightTerm(position, n, light));
}

Frame renderBuiltin(const std::string& view, uint32_t width, uint32_t height) {
  auto& ctx = test::context();
  static const Scene scene = builtinScene();
  const Camera* camera = scene.findCamera(view);
  EXPECT_NE(camera, nullptr) << view;
  Frame f{width, height, {}, {}, scene.lights.at(0).position};
  Raster raster(ctx, scene);
  raster.render(camera ? *camera : scene.cameras.at(0), f.light, width, height, f.device, &f.host);
  return f;
}

TEST(LitRays, MatchTheCpuReferenceInEveryOrder) {
  auto& ctx = test::context();
  Frame f = renderBuiltin("fur", 200, 130);  // not a multiple of the 64-pixel Morton tile
  rays::LitRays rays(ctx, f.width, f.height);
  for (auto order : {rays::RayOrder::Hilbert, rays::RayOrder::ScreenMorton, rays::RayOrder::ScreenRows}) {
    vk::Commands cmd(ctx);
    rays.record(cmd, f.device, f.light, order);
    cmd.submit();
    std::vector<uint32_t> want = rays::referenceRayOrder(f.host, f.light, order);
    ASSERT_EQ(rays.readCount(), f.host.litCount()) << rays::rayOrderName(order);
    ASSERT_GT(want.size(), 1000u);
    const std::vector<uint32_t> got = vk::download<uint32_t>(ctx, rays.samples(), want.size());
    if (order != rays::RayOrder::Hilbert || ctx.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
      EXPECT_SAME_ARRAY(got, want, rays::rayOrderName(order));
      continue;
    }
    // A GPU may put a ray near a cell edge in the neighbouring cell (isRayKeyUpToDivision), and its faces'
    // boxes may differ from the CPU's by the same divisions' rounding: the order is then the stable sort
    // of the lit samples by the keys it computed, each the CPU's up to a division on the GPU's grid.
    const std::vector<uint32_t> keys = vk::download<uint32_t>(ctx, rays.keys(), want.size());
    const rays::FaceBounds bounds = rays::FaceBounds::fromWords(vk::download<uint32_t>(ctx, rays.bounds(), RAY_BOUNDS_WORDS));
    std::vector<uint32_t> lit;
    for (uint32_t i = 0; i < f.host.size(); ++i)
      if (f.host.isLit(i)) lit.push_back(i);
    const rays::FaceBounds cpu = rays::referenceBounds(f.host, f.light);
    EXPECT_EQ(bounds.counts, cpu.counts) << "the faces come from comparisons alone";
    std::array<glm::vec4, 6> grids;
    for (uint32_t face = 0; face < 6; ++face) {
      for (int c = 0; c < 4; ++c)
        ASSERT_LE(std::abs(int64_t(bounds.boxes[face][c]) - int64_t(cpu.boxes[face][c])), 3) << "face " << face << " box word " << c;
      grids[face] = bounds.keyGrid(face);
    }
    std::vector<uint32_t> a = got, b = want;
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    ASSERT_EQ(a, b) << "not the lit samples";
    size_t differ = 0;
    for (size_t i = 0; i < got.size(); ++i) {
      const glm::vec3 d = glm::vec3(f.host.position[got[i]]) - f.light;
      const uint32_t face = rays::rayFace(d);
      const glm::vec4 grid = face < 6 ? grids[face] : glm::vec4(0);
      ASSERT_TRUE(isRayKeyUpToDivision(d, keys[i], grid)) << "sample " << got[i] << " at " << i;
      differ += keys[i] != (face < 6 ? rays::faceKey(d, face, grid) : rays::kRayKeyDegenerate);
      if (i > 0) {
        ASSERT_TRUE(keys[i - 1] < keys[i] || (keys[i - 1] == keys[i] && got[i - 1] < got[i]))
            << "not a stable sort at " << i;
      }
    }
    std::printf("hilbert order: %zu of %zu keys differ from the CPU's by a division's rounding\n", differ, got.size());
  }
}

// The fused compaction's enumeration (rectDomain, rectDomainPixel): its real positions are the rect's
// pixels, each once, in row-major order; its rows are whole invocations (an invocation's positions are
// consecutive pixels of one row); an empty rect enumerates padding alone; no rect of an image exceeds
// maxRectDomain (the buffers' size).
TEST(LitRays, TheRectDomainEnumeratesTheRectsPixelsInRowOrder) {
  struct Case {
    uint32_t width, height;
    PixelRect rect;
  };
  const Case cases[] = {{700, 523, {0, 0, 700, 523}},  {700, 523, {251, 97, 417, 301}}, {64, 64, {0, 0, 64, 64}},
                        {64, 64, {32, 5, 64, 6}},      {1024, 1024, {279, 391, 763, 685}}, {33, 2, {32, 1, 33, 2}},
                        {700, 523, {0, 0, 0, 0}},      {700, 523, {10, 10, 10, 400}}};
  for (const Case& c : cases) {
    const rays::RectDomain d = rays::rectDomain(c.rect);
    const std::string what = std::to_string(c.rect.x0) + "," + std::to_string(c.rect.y0) + " .. " +
                             std::to_string(c.rect.x1) + "," + std::to_string(c.rect.y1);
    EXPECT_EQ(d.span % SCAN_ITEMS, 0u) << what;
    EXPECT_EQ(d.size % d.span, 0u) << what;
    EXPECT_LE(d.size, rays::maxRectDomain(c.width, c.height)) << what;
    std::vector<uint32_t> real;
    const glm::uvec4 r(d.x0, d.y0, d.x1, d.y1);
    for (uint32_t i = 0; i < d.size; ++i)
      if (i % d.span < d.x1 - d.x0) real.push_back(rays::rectDomainPixel(i, r, d.span, c.width));
    std::vector<uint32_t> want;
    for (uint32_t y = c.rect.y0; y < c.rect.y1; ++y)
      for (uint32_t x = c.rect.x0; x < c.rect.x1; ++x) want.push_back(y * c.width + x);
    EXPECT_EQ(real, want) << what;
    for (uint32_t i = 0; i + SCAN_ITEMS <= d.size; i += SCAN_ITEMS)  // an invocation: one row, consecutive
      EXPECT_EQ(rays::rectDomainPixel(i + SCAN_ITEMS - 1, r, d.span, c.width),
                rays::rectDomainPixel(i, r, d.span, c.width) + SCAN_ITEMS - 1)
          << what << ", position " << i;
  }
}

TEST(LitRays, SampleAtTheLightIsNeverLitAndEqualKeysKeepRowOrder) {
  auto& ctx = test::context();
  const glm::vec3 light(0.5f, 2.0f, -1.0f);
  // A 4x3 G-buffer written by hand: (offset from the light, facing it?) per pixel, row-major. A sample at
  // the light faces nothing: its light term is 0 (core/shared.h lightTerm), so it is no lit sample.
  const std::vector<std::pair<glm::vec3, bool>> pixels = {
      {{0, 0, 0}, true},   {{1, 1, 0}, true},    {{0, -3, 0}, true},   {{2, 2, 0}, true},  // at the light; x == y tie
      {{0, 0, 5}, false},  {{-1, 1, 1}, true},   {{0, 0, -2}, true},   {{0, 0, 0}, true},  // unlit; tie -> x; at light
      {{1, 0, 0}, true},   {{0, 0, 0}, false},   {{4, 0, 0}, true},    {{0, 1e-3f, 0}, true}};
  DeviceGBuffer g;
  g.width = 4, g.height = 3;
  std::vector<glm::vec4> pos, nrm;
  for (auto& [offset, lit] : pixels) {
    pos.push_back(glm::vec4(light + offset, 1.0f));
    nrm.push_back(normalFor(light + offset, light, lit));
  }
  g.position = vk::createBuffer(ctx, pos.size() * 16), g.normal = vk::createBuffer(ctx, nrm.size() * 16);
  vk::upload(ctx, g.position, pos.data(), pos.size() * 16);
  vk::upload(ctx, g.normal, nrm.data(), nrm.size() * 16);
  GBuffer host{g.width, g.height, pos, nrm};

  rays::LitRays rays(ctx, g.width, g.height);
  vk::Commands cmd(ctx);
  rays.record(cmd, g, light, rays::RayOrder::Hilbert);
  cmd.submit();
  const uint32_t n = rays.readCount();
  ASSERT_EQ(n, 8u);
  std::vector<uint32_t> samples = vk::download<uint32_t>(ctx, rays.samples(), n), keys = vk::download<uint32_t>(ctx, rays.keys(), n);
  EXPECT_SAME_ARRAY(samples, rays::referenceRayOrder(host, light, rays::RayOrder::Hilbert), "hand-made G-buffer");
  auto at = [&](uint32_t pixel) { return std::find(samples.begin(), samples.end(), pixel) - samples.begin(); };
  // The samples at the light (pixels 0 and 7) are not lit samples; no lit ray is degenerate.
  EXPECT_EQ(at(0), std::ptrdiff_t(n));
  EXPECT_EQ(at(7), std::ptrdiff_t(n));
  for (uint32_t k : keys) EXPECT_NE(k, rays::kRayKeyDegenerate);
  EXPECT_EQ(at(10), at(8) + 1) << "equal keys keep row-major order";
  // Each key in its face's run (the faces' slots from the GPU's counts).
  const rays::FaceBounds bounds = rays::FaceBounds::fromWords(vk::download<uint32_t>(ctx, rays.bounds(), RAY_BOUNDS_WORDS));
  auto inRun = [&](uint32_t key, uint32_t face) {
    uint32_t c[6];
    std::copy(bounds.counts.begin(), bounds.counts.end(), c);
    const glm::uvec2 s = rays::faceKeySlot(face, c);
    return s.x > 0 && key >= s.y && key - s.y < (1u << (2 * s.x));
  };
  EXPECT_TRUE(inRun(keys[at(1)], 0)) << "x == y goes to +x";
  EXPECT_TRUE(inRun(keys[at(5)], 1)) << "|x| == |y| == |z| goes to -x";
}

// ray_bounds.comp reads a row's members of the subset from firstBoundsSampleFrom: the least j whose
// pixel (boundsSample) is at or after p, for pixel counts below, at and far above RAY_BOUNDS_SAMPLES (up
// to 2^32 - 1, where p RAY_BOUNDS_SAMPLES leaves 32 bits).
TEST(RayKeys, FirstBoundsSampleFromIsTheFirstSubsetMemberAtOrAfterAPixel) {
  std::mt19937 rng(5);
  for (uint32_t n : {1u, 7u, 1000u, 16383u, 16384u, 16385u, 700u * 523u, 1u << 20, 4000000u, 0xFFFFFFFFu}) {
    std::vector<uint32_t> ps = {0, n / 2, n - 1, n};
    for (int k = 0; k < 200; ++k) ps.push_back(uint32_t(uint64_t(rng()) % (uint64_t(n) + 1)));
    for (uint32_t p : ps) {
      uint32_t want = RAY_BOUNDS_SAMPLES;  // by bisection over the monotone boundsSample
      for (uint32_t lo = 0, hi = RAY_BOUNDS_SAMPLES; lo < hi;) {
        const uint32_t mid = (lo + hi) / 2;
        if (rays::boundsSample(mid, n) >= p) want = mid, hi = mid;
        else lo = mid + 1;
      }
      ASSERT_EQ(rays::firstBoundsSampleFrom(p, n), want) << "pixel " << p << " of " << n;
    }
  }
}

TEST(RayKeys, OrderedBitsSortAsTheFloatsDo) {
  const float inf = std::numeric_limits<float>::infinity(), tiny = std::numeric_limits<float>::denorm_min();
  std::vector<float> v = {-inf, -CS_FLT_MAX, -1.0f, -tiny, -0.0f, 0.0f, tiny, 1e-30f, 1.0f, CS_FLT_MAX, inf};
  std::mt19937 rng(3);
  for (int i = 0; i < 10000; ++i) v.push_back(std::ldexp(std::uniform_real_distribution<float>(-1, 1)(rng), int(rng() % 200) - 100));
  std::sort(v.begin(), v.end());
  for (size_t i = 0; i < v.size(); ++i) {
    EXPECT_EQ(rays::fromOrderedBits(rays::orderedBits(v[i])), v[i]);
    EXPECT_NE(rays::orderedBits(v[i]), RAY_BOUNDS_EMPTY);
    if (i > 0 && v[i - 1] < v[i]) {
      EXPECT_LT(rays::orderedBits(v[i - 1]), rays::orderedBits(v[i])) << v[i - 1] << " < " << v[i];
    }
  }
}

// A box's four words as ray_bounds.comp leaves them (RAY_BOUNDS_SAMPLES): u in [u0, u1], v in [v0, v1].
glm::uvec4 boxWords(float u0, float v0, float u1, float v1) {
  return glm::uvec4(rays::orderedBits(u0), rays::orderedBits(v0), rays::orderedBits(-u1), rays::orderedBits(-v1));
}

TEST(RayKeys, AFittedGridIsTheFacesGridZoomedOntoItsBox) {
  using glm::uvec2;
  using glm::uvec4;
  using glm::vec4;
  const uint32_t order = RAY_KEY_MAX_ORDER, n = 1u << order;
  EXPECT_EQ(rays::fittedFaceGrid(uvec4(RAY_BOUNDS_EMPTY), order), rays::wholeFaceGrid(order)) << "no sample on the face";
  EXPECT_EQ(rays::fittedFaceGrid(boxWords(-0.9f, -0.1f, 0.2f, 0.3f), order), rays::wholeFaceGrid(order))
      << "no half of the face holds it";
  // u in [0.25, 0.5] lies in the face's half [0, 1]; v in [-0.5, 0.5] in the half-offset one: square cells.
  const vec4 g = rays::fittedFaceGrid(boxWords(0.25f, -0.5f, 0.5f, 0.5f), order);
  EXPECT_EQ(g, vec4(0.0f, -0.5f, float(n), float(n)));
  EXPECT_EQ(rays::gridCell({0.25f, -0.5f}, g, order), uvec2(n / 4, 0));
  EXPECT_EQ(rays::gridCell({0.5f, 0.5f}, g, order), uvec2(n / 2, n - 1));
  EXPECT_EQ(rays::gridCell({-1.0f, 1.0f}, g, order), uvec2(0, n - 1)) << "outside the square: its edge cells";
  // A box 1e-3 wide: zoomed until its square is less than twice its size, so it spans a quarter of the
  // cells or more.
  const vec4 small = rays::fittedFaceGrid(boxWords(0.3f, 0.1f, 0.301f, 0.1005f), order);
  const uvec2 a = rays::gridCell({0.3f, 0.1f}, small, order), b = rays::gridCell({0.301f, 0.1005f}, small, order);
  EXPECT_GE(b.x - a.x, n / 4) << "u spans " << a.x << " .. " << b.x;
  EXPECT_LT(b.x, n);
  EXPECT_EQ(small.z, small.w) << "square cells";
  // One direction: the deepest zoom, a finite grid within a cell of it (the start is rounded in fp32).
  const vec4 point = rays::fittedFaceGrid(boxWords(0.3f, 0.1f, 0.3f, 0.1f), order);
  EXPECT_EQ(point.z, float(n) / std::ldexp(1.0f, 1 - RAY_KEY_MAX_ZOOM));
  EXPECT_NEAR(point.x, 0.3f, 2e-7f);
  EXPECT_NEAR(point.y, 0.1f, 2e-7f);
}

// The far-light frame's key (rays/hilbert.h frameKeyGrid, frameRayKey): one grid of square cells at the
// subset's box, its larger side spanning every cell (the scene's projection when the subset saw nothing);
// 18 bits, degenerate rays last, rays outside the box on the edge cells.
TEST(RayKeys, TheFarFramesGridIsFittedToTheSubsetsBox) {
  using glm::uvec2;
  using glm::uvec4;
  using glm::vec3;
  using glm::vec4;
  const uint32_t order = RAY_KEY_MAX_ORDER, n = 1u << order;
  auto cell = [&](vec4 g, float u, float v) { return rays::gridCell({u, v}, vec4(g.x, g.y, g.z, g.z), order); };
  // The scene's projection: u in [-0.01, 0.03], v in [-0.02, 0].
  const vec4 rect(-0.01f, -0.02f, 1.0f / 0.04f, 1.0f / 0.02f);
  const vec4 whole = rays::frameKeyGrid(uvec4(RAY_BOUNDS_EMPTY), rect, order);
  EXPECT_EQ(uint32_t(whole.w), order) << "the run of keys starts at 0: the slot is the order";
  EXPECT_EQ(glm::vec2(whole), glm::vec2(-0.01f, -0.02f)) << "no sample: the scene's projection";
  EXPECT_EQ(cell(whole, -0.01f, -0.02f), uvec2(0, 0));
  EXPECT_EQ(cell(whole, 0.02999f, 0.0f).x, n - 1) << "u, the larger side, spans every cell";
  EXPECT_NEAR(double(cell(whole, 0.02999f, 0.0f).y), n / 2.0, 1.0) << "v, half as long, half of them: square cells";
  // A box of 1/32 x 1/64 (exact in fp32) in a projection of [-1, 1]^2: its own grid, the larger side
  // spanning every cell again.
  const vec4 wide(-1.0f, -1.0f, 0.5f, 0.5f);
  const vec4 g = rays::frameKeyGrid(boxWords(0.25f, -0.5f, 0.28125f, -0.484375f), wide, order);
  EXPECT_EQ(g, vec4(0.25f, -0.5f, float(n) * 32.0f, float(order)));
  EXPECT_EQ(cell(g, 0.25f, -0.5f), uvec2(0, 0));
  EXPECT_EQ(cell(g, 0.28125f - 1e-6f, -0.484375f), uvec2(n - 1, n / 2));
  EXPECT_EQ(cell(g, -1.0f, -1.0f), uvec2(0, 0)) << "outside the box: the edge cells";
  EXPECT_EQ(cell(g, 1.0f, 1.0f), uvec2(n - 1, n - 1));
  // One direction: a finite grid, its rays in one cell.
  const vec4 point = rays::frameKeyGrid(boxWords(0.001f, -0.005f, 0.001f, -0.005f), rect, order);
  EXPECT_TRUE(std::isfinite(point.z)) << point.z;
  EXPECT_EQ(cell(point, 0.001f, -0.005f), uvec2(0, 0));
  const vec4 cells(g.x, g.y, g.z, g.z);
  // Keys: the Hilbert index of the cell, at most RAY_KEY_LAST; degenerate rays RAY_KEY_DEGENERATE, after all.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  uint32_t largest = 0;
  for (int i = 0; i < 20000; ++i) {
    const vec3 d(u(rng) * 5.0f, u(rng) * 5.0f, 5.0f);
    const uint32_t key = rays::frameRayKey(d, g);
    const uvec2 c = rays::gridCell(rays::frameUV(d), cells, order);
    ASSERT_EQ(key, std::min(rays::hilbertIndex(c.x, c.y, order), rays::kRayKeyLast)) << i;
    ASSERT_EQ(rays::frameCodeKey(rays::frameCellCode(d, g), g), key) << i;
    largest = std::max(largest, key);
  }
  EXPECT_EQ(largest, rays::kRayKeyLast) << "the last cell shares the key before it";
  EXPECT_EQ(rays::frameRayKey(vec3(0.9f, -0.9f, 1.0f) * 1e3f, g), rays::kRayKeyLast) << "the curve's end (n - 1, 0)";
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  for (vec3 d : {vec3(0, 0, 0), vec3(0.001f, 0, -1), vec3(0, 0, -0.0f), vec3(inf, 0, 1), vec3(0, nan, 1), vec3(0, 0, inf),
                 vec3(1e30f, 0, 1e-20f)})
    EXPECT_EQ(rays::frameRayKey(d, g), rays::kRayKeyDegenerate) << d.x << ", " << d.y << ", " << d.z;
  EXPECT_EQ(sort::radixPasses(rays::kRayKeyBits), 2u);
}

// 96 x 80 lit samples on a 1e-3 x 1e-3 patch of face -z, 50 units from the light ((0.2, -0.1) and up of
// its face coordinates), but for pixel 7, (0, 3, 0) from the light (face +y); every normal faces the light.
Frame sliverOfRays() {
  auto& ctx = test::context();
  Frame f{96, 80, {}, {}, glm::vec3(1.0f, -2.0f, 3.0f)};
  std::vector<glm::vec4> pos, nrm;
  for (uint32_t y = 0; y < f.height; ++y)
    for (uint32_t x = 0; x < f.width; ++x) {
      const glm::vec3 d(0.2f + 1e-3f * float(x) / f.width, -0.1f + 1e-3f * float(y) / f.height, -1.0f);
      pos.push_back(glm::vec4(f.light + d * 50.0f, 1.0f));
      nrm.push_back(normalFor(glm::vec3(pos.back()), f.light, true));
    }
  pos[7] = glm::vec4(f.light + glm::vec3(0, 3, 0), 1.0f);
  nrm[7] = normalFor(glm::vec3(pos[7]), f.light, true);
  f.device.width = f.width, f.device.height = f.height;
  f.device.position = vk::createBuffer(ctx, pos.size() * 16), f.device.normal = vk::createBuffer(ctx, nrm.size() * 16);
  vk::upload(ctx, f.device.position, pos.data(), pos.size() * 16);
  vk::upload(ctx, f.device.normal, nrm.data(), nrm.size() * 16);
  f.host = GBuffer{f.width, f.height, pos, nrm};
  return f;
}

// Rays within a sliver of a face (a zoomed view, a distant light): the fitted grid gives nearly every ray
// a cell of its own, where the whole face's grid would put hundreds in one; the GPU's boxes and order
// are the CPU reference's.
TEST(LitRays, AFittedGridSeparatesRaysThatTheWholeFaceGridWouldLump) {
  auto& ctx = test::context();
  const Frame f = sliverOfRays();  // pixel 7: one ray on face +y, alone there
  const glm::vec3 light = f.light;
  const uint32_t w = f.width, h = f.height;
  const std::vector<glm::vec4>& pos = f.host.position;
  const GBuffer& host = f.host;
  rays::LitRays rays(ctx, w, h);
  vk::Commands cmd(ctx);
  rays.record(cmd, f.device, light, rays::RayOrder::Hilbert);
  cmd.submit();
  const uint32_t count = rays.readCount();
  ASSERT_EQ(count, w * h);
  const std::vector<uint32_t> keys = vk::download<uint32_t>(ctx, rays.keys(), count);
  const std::set<uint32_t> fitted(keys.begin(), keys.end());
  std::set<uint32_t> whole;
  for (const glm::vec4& p : pos) whole.insert(rays::rayKey(glm::vec3(p) - light));
  std::printf("    %u rays: %zu distinct keys on fitted grids, %zu on the whole faces' grids\n", count, fitted.size(), whole.size());
  EXPECT_GT(fitted.size(), size_t(0.9 * count));
  EXPECT_LT(whole.size(), size_t(0.01 * count));
  const std::vector<uint32_t> words = vk::download<uint32_t>(ctx, rays.bounds(), 24);
  EXPECT_NE(words[4 * 2], RAY_BOUNDS_EMPTY) << "face +y has its one ray";
  for (uint32_t face : {0u, 1u, 3u, 4u}) EXPECT_EQ(words[4 * face], RAY_BOUNDS_EMPTY) << "face " << face << " has none";
  if (ctx.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
    EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.samples(), count),
                      rays::referenceRayOrder(host, light, rays::RayOrder::Hilbert), "fitted grids");
  }
}

// The same in the far-light frame: rays within a hundredth of the scene's projection (KeysPush::rect)
// get nearly a cell each on the grid fitted to the subset's box, where a 2^9 grid over the projection
// would put them in a handful; the GPU's box and order are the CPU reference's.
TEST(LitRays, TheFarFramesFittedGridSeparatesRaysThatAGridOverTheSceneWouldLump) {
  auto& ctx = test::context();
  const Frame f = sliverOfRays();  // pixel 7 at right angles to the frame's z: degenerate, last
  const glm::vec3 light = f.light;
  const uint32_t w = f.width, h = f.height;
  const std::vector<glm::vec4>& pos = f.host.position;
  const GBuffer& host = f.host;
  const DeviceGBuffer& g = f.device;
  // z along -z, x along -x, y along y, the light at the origin: the patch at frame coordinates
  // [-0.201, -0.2] x [-0.1, -0.099].
  rays::KeysPush push{};
  push.light = glm::vec4(light, 1.0f);
  push.framed = 1;
  push.rowX = glm::vec4(-1, 0, 0, 0), push.rowY = glm::vec4(0, 1, 0, 0), push.rowZ = glm::vec4(0, 0, -1, 0);
  push.origin = glm::vec4(light, 1.0f);
  push.rect = glm::vec4(-0.25f, -0.4f, 2.0f, 2.0f);  // the scene's projection, half a unit a side
  rays::LitRays rays(ctx, w, h);
  ASSERT_TRUE(rays.fusedKeys());
  vk::Commands cmd(ctx);
  rays.recordCompactionWithKeys(cmd, g, push);
  rays.recordSort(cmd, rays.count());
  cmd.submit();
  EXPECT_EQ(rays.keyBits(), rays::kRayKeyBits);
  const uint32_t count = rays.readCount();
  ASSERT_EQ(count, w * h);
  const std::vector<uint32_t> keys = vk::download<uint32_t>(ctx, rays.keys(), count);
  const std::vector<uint32_t> samples = vk::download<uint32_t>(ctx, rays.samples(), count);
  EXPECT_EQ(samples.back(), 7u) << "the degenerate ray sorts last";
  EXPECT_EQ(keys.back(), rays::kRayKeyDegenerate);
  const std::set<uint32_t> fitted(keys.begin(), keys.end());
  const glm::vec4 projection = rays::frameKeyGrid(glm::uvec4(RAY_BOUNDS_EMPTY), push.rect, RAY_KEY_MAX_ORDER);
  std::set<uint32_t> whole;
  for (const glm::vec4& p : pos) whole.insert(rays::frameRayKey(glm::vec3(light.x - p.x, p.y - light.y, light.z - p.z), projection));
  std::printf("    %u rays: %zu distinct keys on the fitted grid, %zu on the projection's\n", count, fitted.size(), whole.size());
  EXPECT_GT(fitted.size(), size_t(0.9 * count));
  EXPECT_LT(whole.size(), size_t(0.01 * count));
  const rays::FaceBounds bounds = rays::FaceBounds::fromWords(vk::download<uint32_t>(ctx, rays.bounds(), RAY_BOUNDS_WORDS));
  EXPECT_GT(bounds.counts[0], 0u) << "the subset's samples, on face 0's words";
  for (uint32_t face = 1; face < 6; ++face) EXPECT_EQ(bounds.counts[face], 0u) << "face " << face;
  if (ctx.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
    const rays::FaceBounds cpu = rays::referenceBounds(host, push);
    EXPECT_EQ(bounds.boxes[0], cpu.boxes[0]);
    EXPECT_EQ(bounds.counts, cpu.counts);
    EXPECT_SAME_ARRAY(samples, rays::referenceRayOrder(host, push), "the far frame's fitted grid");
  }
}

TEST(LitRays, StepsWithAHostCountMatchTheFusedRecording) {
  auto& ctx = test::context();
  Frame f = renderBuiltin("room", 160, 120);
  rays::LitRays rays(ctx, f.width, f.height);
  vk::Commands cmd(ctx);
  rays.recordCompaction(cmd, f.device, f.light, rays::RayOrder::ScreenRows);
  cmd.submit();
  const uint32_t n = rays.readCount();  // the cone path's one readback per frame
  rays.recordKeys(cmd, f.device, f.light, n);
  rays.recordSort(cmd, n);
  cmd.submit();
  EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.samples(), n),
                    rays::referenceRayOrder(f.host, f.light, rays::RayOrder::Hilbert), "host-count steps");
  std::vector<uint32_t> keys = vk::download<uint32_t>(ctx, rays.keys(), n);
  EXPECT_TRUE(std::is_sorted(keys.begin(), keys.end()));
}

// The fused compaction (LitRays::recordCompactionWithKeys: lit bits, block scan, the faces' boxes found
// from the bits, keys written as the sort's pairs) gives the steps' order, keys and boxes bit for bit --
// world keys and rotated-frame keys -- on G-buffers whose lit pixels are isolated among empty blocks, in
// the last partial block only, dense, complete, or absent; and on a CPU device the CPU reference's.
TEST(LitRays, FusedCompactionAndKeysMatchTheStepsOnSparseAndDenseFrames) {
  auto& ctx = test::context();
  const uint32_t w = 700, h = 523, pixels = w * h;  // 179 blocks of SCAN_BLOCK, the last one partial
  const glm::vec3 light(0.3f, 1.5f, -2.0f);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), r(0.5f, 40.0f);
  // Two fields of directions: a smooth one with noise on top (few neighbours share a key), and one of
  // stretches of 1 to 40 pixels of a row that share a direction (runs of equal keys, cut by the
  // invocations' 32 positions, by unlit pixels and by the next stretch; a run of a whole 32).
  std::vector<glm::vec4> noisy(pixels), stretches(pixels);
  for (uint32_t i = 0, left = 0; i < pixels; ++i) {
    const float a = 6.0f * float(i % w) / w, b = 3.0f * float(i / w) / h;
    const glm::vec3 dir = glm::normalize(glm::vec3(std::cos(a), std::sin(b) + 0.1f * u(rng), std::sin(a) + 0.1f * u(rng)));
    noisy[i] = glm::vec4(light + dir * r(rng), 1.0f);
    if (left == 0 || i % w == 0) left = 1 + rng() % 40;  // a new stretch: this pixel's position
    else stretches[i] = stretches[i - 1];                 // the stretch's position again: its key
    if (stretches[i].w == 0.0f) stretches[i] = noisy[i];
    --left;
  }
  // empty: the unlit pixels have no geometry either (position.w 0), as around a far view's model, where
  // lit_runs.comp skips four positions at a time.
  struct Pattern {
    const char* name;
    std::function<bool(uint32_t)> lit;
    bool empty = false;
  };
  const Pattern patterns[] = {
      {"isolated", [](uint32_t i) { return i % 9973 == 17; }},
      // Three lit pixels, members of the boxes' subset, in the first, middle and last rows: the steps'
      // boxes (recordKeys with the device count) from three workgroups, not RAY_BOUNDS_GROUPS, whose 192
      // invocations stride over the 523 rows by the workgroups launched.
      {"three", [&](uint32_t i) {
         return i == rays::boundsSample(3, pixels) || i == rays::boundsSample(RAY_BOUNDS_SAMPLES / 2, pixels) ||
                i == rays::boundsSample(RAY_BOUNDS_SAMPLES - 2, pixels);
       }},
      {"last block only", [&](uint32_t i) { return i >= pixels - 300 && i % 3 != 0; }},
      {"dense", [](uint32_t i) { return (i * 2654435761u) % 10 < 7; }},
      {"all", [](uint32_t) { return true; }},
      {"none", [](uint32_t) { return false; }},
      {"dense among empty pixels", [](uint32_t i) { return (i * 2654435761u) % 10 < 7; }, true},
      {"a few rows among empty ones", [&](uint32_t i) { return (i / w) % 37 < 3 && i % 11 != 0; }, true},
      {"a block among empty pixels",
       [&](uint32_t i) { return i % w >= 251 && i % w < 417 && i / w >= 97 && i / w < 301 && i % 5 != 0; }, true},
  };
  rays::LitRays rays(ctx, w, h);
  ASSERT_TRUE(rays.fusedKeys());
  for (const std::vector<glm::vec4>* field : {&noisy, &stretches})
  for (const Pattern& pattern : patterns)
    for (bool framed : {false, true}) {
      std::vector<glm::vec4> pos = *field, nrm(pixels);
      for (uint32_t i = 0; i < pixels; ++i) {
        nrm[i] = normalFor(glm::vec3(pos[i]), light, pattern.lit(i));
        if (pattern.empty && !pattern.lit(i)) pos[i].w = 0.0f;
      }
      DeviceGBuffer g;
      g.width = w, g.height = h;
      g.position = vk::createBuffer(ctx, uint64_t(pixels) * 16), g.normal = vk::createBuffer(ctx, uint64_t(pixels) * 16);
      vk::upload(ctx, g.position, pos.data(), uint64_t(pixels) * 16);
      vk::upload(ctx, g.normal, nrm.data(), uint64_t(pixels) * 16);
      GBuffer host{w, h, pos, nrm};
      rays::KeysPush push{};
      push.light = glm::vec4(light, 1.0f);
      if (framed) {  // a frame turned a quarter about y, keys over a rect of its z = 1 plane
        push.framed = 1;
        push.rowX = glm::vec4(0, 0, 1, 0), push.rowY = glm::vec4(0, 1, 0, 0), push.rowZ = glm::vec4(-1, 0, 0, 0);
        push.origin = glm::vec4(light, 1.0f);
        push.lightFrame = glm::vec4(0.0f);
        push.rect = glm::vec4(-2.0f, -2.0f, 0.25f, 0.25f);
      }
      const std::string what = std::string(field == &noisy ? "noisy, " : "stretches, ") + pattern.name +
                               (framed ? ", rotated frame" : ", world keys");
      // Steps: compaction, keys, sort.
      vk::Commands cmd(ctx);
      rays.recordCompaction(cmd, g, light, rays::RayOrder::ScreenRows);
      rays.recordKeys(cmd, g, push, rays.count());
      rays.recordSort(cmd, rays.count());
      cmd.submit();
      const uint32_t n = rays.readCount();
      ASSERT_EQ(n, host.litCount()) << what;
      const std::vector<uint32_t> samples = vk::download<uint32_t>(ctx, rays.samples(), n);
      const std::vector<uint32_t> keys = vk::download<uint32_t>(ctx, rays.keys(), n);
      const std::vector<uint32_t> bounds = vk::download<uint32_t>(ctx, rays.bounds(), 24);
      if (field == &stretches && std::string(pattern.name) == "all") {  // runs as long as they come
        size_t whole = 0;
        for (size_t j = 0; j + 31 < n; ++j)
          whole += samples[j] % 32 == 0 && samples[j + 31] == samples[j] + 31 && keys[j] == keys[j + 31];
        EXPECT_GT(whole, 100u) << what << ": runs of a whole invocation's 32 pixels";
      }
      // Fused.
      rays.recordCompactionWithKeys(cmd, g, push);
      rays.recordSort(cmd, rays.count());
      cmd.submit();
      ASSERT_EQ(rays.readCount(), n) << what;
      EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.samples(), n), samples, what << ": samples");
      EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.keys(), n), keys, what << ": keys");
      EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.bounds(), 24), bounds, what << ": the boxes");
      const std::vector<uint32_t> wholeBounds = vk::download<uint32_t>(ctx, rays.bounds(), RAY_BOUNDS_WORDS);
      // Fused, told the rect of the pixels with geometry (DeviceGBuffer::geometryRect, as the camera pass
      // gives it): the positions outside are not read, and nothing changes.
      if (pattern.empty) {
        PixelRect tight{w, h, 0, 0};
        for (uint32_t i = 0; i < pixels; ++i)
          if (pos[i].w != 0.0f)
            tight = {std::min(tight.x0, i % w), std::min(tight.y0, i / w), std::max(tight.x1, i % w + 1),
                     std::max(tight.y1, i / w + 1)};
        g.geometryRect = tight;
        rays.recordCompactionWithKeys(cmd, g, push);
        rays.recordSort(cmd, rays.count());
        cmd.submit();
        ASSERT_EQ(rays.readCount(), n) << what << ", within its geometry's rect";
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.samples(), n), samples, what << ": samples in the rect");
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.keys(), n), keys, what << ": keys in the rect");
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.bounds(), RAY_BOUNDS_WORDS),
                          wholeBounds,
                          what << ": the boxes and counts from the subset's members in the rect");
        // An empty rect: no position is read, nothing is lit, and the sort takes no run.
        g.geometryRect = PixelRect{0, 0, 0, 0};
        rays.recordCompactionWithKeys(cmd, g, push);
        rays.recordSort(cmd, rays.count());
        cmd.submit();
        EXPECT_EQ(rays.readCount(), 0u) << what << ", in an empty rect";
        // The screen orders' compaction (lit_count.comp) likewise, in rows and in Morton tiles.
        for (rays::RayOrder order : {rays::RayOrder::ScreenRows, rays::RayOrder::ScreenMorton}) {
          g.geometryRect = PixelRect{};
          rays.recordCompaction(cmd, g, light, order);
          cmd.submit();
          const std::vector<uint32_t> whole = vk::download<uint32_t>(ctx, rays.samples(), rays.readCount());
          g.geometryRect = tight;
          rays.recordCompaction(cmd, g, light, order);
          cmd.submit();
          EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.samples(), rays.readCount()), whole,
                            what << ": " << rays::rayOrderName(order) << " in the rect");
          // A rect that leaves lit pixels out: lit_count.comp counts none outside it (which shows the
          // rect is read; the camera pass's never leaves any out).
          const PixelRect inner{tight.x0 + 7, tight.y0 + 5, tight.x1 - 9, tight.y1 - 3};
          if (inner.x0 >= inner.x1 || inner.y0 >= inner.y1) continue;
          uint32_t within = 0;
          for (uint32_t i = 0; i < pixels; ++i)
            within += host.isLit(i) && i % w >= inner.x0 && i % w < inner.x1 && i / w >= inner.y0 && i / w < inner.y1;
          ASSERT_LT(within, n) << what;
          g.geometryRect = inner;
          rays.recordCompaction(cmd, g, light, order);
          cmd.submit();
          EXPECT_EQ(rays.readCount(), within) << what << ": " << rays::rayOrderName(order) << " in a smaller rect";
        }
        g.geometryRect = PixelRect{};
      }
      // Fused, writing the sorted rays' records as the cone tree's rays() holds them: the record of the
      // j-th ray is its sample's position (float bits) and pixel, in the same order; the keys as before.
      {
        vk::Buffer records = vk::createBuffer(ctx, uint64_t(pixels) * 16);
        vk::Buffer positionsOnly = vk::createBuffer(ctx, 16);
        EXPECT_THROW(rays.recordSort(cmd, rays.count(), &positionsOnly, &g.position), Error) << what << ": too small";
        rays.recordCompactionWithKeys(cmd, g, push);
        EXPECT_TRUE(rays.recordSort(cmd, rays.count(), &records, &g.position)) << what;
        cmd.submit();
        std::vector<uint32_t> want(size_t(n) * 4);
        for (uint32_t j = 0; j < n; ++j) {
          const glm::vec4 p = pos[samples[j]];
          want[4 * j] = glm::floatBitsToUint(p.x), want[4 * j + 1] = glm::floatBitsToUint(p.y);
          want[4 * j + 2] = glm::floatBitsToUint(p.z), want[4 * j + 3] = samples[j];
        }
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, records, uint64_t(n) * 4), want, what << ": records");
        EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.keys(), n), keys, what << ": keys with the records");
        // Without runs to expand (the steps' sort) nothing is written and it says so.
        rays.recordCompaction(cmd, g, light, rays::RayOrder::ScreenRows);
        rays.recordKeys(cmd, g, push, rays.count());
        EXPECT_FALSE(rays.recordSort(cmd, rays.count(), &records, &g.position)) << what;
        cmd.submit();
      }
      if (ctx.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU)
        EXPECT_SAME_ARRAY(samples, rays::referenceRayOrder(host, push), what << ": reference");
    }
}

// Where the sort keeps no pair scratch (pairs past one binding or texel buffer), the fused path is off:
// LitRays records the steps and gives the same order, and asking for the fused path is a clear error.
TEST(LitRays, WithoutPairScratchTheStepsRunAndTheFusedPathIsAClearError) {
  auto& ctx = test::context();
  Frame f = renderBuiltin("room", 160, 120);
  struct Restore {
    ~Restore() { sort::setPairScratchForTesting(-1); }
  } restore;
  sort::setPairScratchForTesting(0);
  rays::LitRays rays(ctx, f.width, f.height);
  EXPECT_FALSE(rays.fusedKeys());
  vk::Commands cmd(ctx);
  rays.record(cmd, f.device, f.light, rays::RayOrder::Hilbert);
  cmd.submit();
  const uint32_t n = rays.readCount();
  EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.samples(), n),
                    rays::referenceRayOrder(f.host, f.light, rays::RayOrder::Hilbert), "steps without pair scratch");
  rays::KeysPush push{};
  push.light = glm::vec4(f.light, 1.0f);
  try {
    rays.recordCompactionWithKeys(cmd, f.device, push);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("fusedKeys"), std::string::npos) << e.what();
  }
}

// Mean angle (radians) between the rays of consecutive samples.
double meanNeighbourAngle(const GBuffer& g, glm::vec3 light, const std::vector<uint32_t>& samples) {
  double sum = 0;
  for (size_t i = 1; i < samples.size(); ++i) {
    glm::dvec3 a = glm::normalize(glm::dvec3(glm::vec3(g.position[samples[i - 1]]) - light));
    glm::dvec3 b = glm::normalize(glm::dvec3(glm::vec3(g.position[samples[i]]) - light));
    sum += std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
  }
  return samples.size() > 1 ? sum / double(samples.size() - 1) : 0.0;
}

TEST(RayKeys, SortedNeighboursAreCloserThanScreenOrder) {
  auto& ctx = test::context();
  double sortedSum = 0, screenSum = 0;
  for (const std::string& view : builtinViewNames()) {
    Frame f = renderBuiltin(view, 256, 192);
    rays::LitRays rays(ctx, f.width, f.height);
    double mean[2];
    for (int s = 0; s < 2; ++s) {
      vk::Commands cmd(ctx);
      rays.record(cmd, f.device, f.light, s == 0 ? rays::RayOrder::Hilbert : rays::RayOrder::ScreenMorton);
      cmd.submit();
      mean[s] = meanNeighbourAngle(f.host, f.light, vk::download<uint32_t>(ctx, rays.samples(), rays.readCount()));
    }
    std::printf("    view %-8s mean angle between neighbouring rays: sorted %.5f rad, screen order %.5f rad (%.1fx)\n",
                view.c_str(), mean[0], mean[1], mean[1] / mean[0]);
    EXPECT_LT(mean[0], mean[1]) << view;
    sortedSum += mean[0], screenSum += mean[1];
  }
  EXPECT_LT(sortedSum, 0.5 * screenSum) << "over all views, sorting at least halves the neighbour angle";
}

TEST(SortGrid, EveryKernelIsCorrectOnTwoDimensionalGrids) {
  auto& ctx = test::context();
  // 10 workgroups per dimension: the scans (98 blocks), compaction and sort (25 tiles; 98 in the GPU shape) below need rows of them.
  sort::setGridLimitForTesting(10);
  struct Reset {
    ~Reset() { sort::setGridLimitForTesting(0); }
  } reset;
  const uint32_t n = 200003;
  std::vector<uint32_t> in = randomWords(n, 21);
  vk::Buffer a = gpuArray(ctx, in), b = vk::createBuffer(ctx, n * 4), word = vk::createBuffer(ctx, 16);
  sort::Scan scan(ctx, n);
  sort::Compact compact(ctx, n);
  sort::RadixSort sorter(ctx, n);
  vk::Commands cmd(ctx);
  scan.record(cmd, a, b, n);
  cmd.submit();
  EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, b, n), exclusiveSum(in), "scan");
  compact.record(cmd, a, n, b, GpuWord(word, 0));
  cmd.submit();
  EXPECT_EQ(vk::download<uint32_t>(ctx, word, 1)[0], uint32_t(n - std::count(in.begin(), in.end(), 0u)));
  Pairs pairs = withPositions(in);
  Pairs got = gpuSorted(sorter, pairs), want = stableSorted(pairs);
  EXPECT_SAME_ARRAY(got.keys, want.keys, "sorted keys");
  EXPECT_SAME_ARRAY(got.values, want.values, "sorted values");
  sort::RadixSort gpuShaped(ctx, n, sort::kGpuSortShape);  // 98 tiles of 2048
  got = gpuSorted(gpuShaped, pairs);
  EXPECT_SAME_ARRAY(got.keys, want.keys, "sorted keys, GPU tile shape");
  EXPECT_SAME_ARRAY(got.values, want.values, "sorted values, GPU tile shape");
  Frame f = renderBuiltin("fur", 300, 200);
  sort::setGridLimitForTesting(20);  // 235 workgroups of pixels, 320 of Morton positions
  rays::LitRays rays(ctx, f.width, f.height);
  for (auto order : {rays::RayOrder::Hilbert, rays::RayOrder::ScreenMorton}) {
    rays.record(cmd, f.device, f.light, order);
    cmd.submit();
    std::vector<uint32_t> ref = rays::referenceRayOrder(f.host, f.light, order);
    EXPECT_SAME_ARRAY(vk::download<uint32_t>(ctx, rays.samples(), ref.size()), ref, rays::rayOrderName(order));
  }
}


}  // namespace
}  // namespace cs
