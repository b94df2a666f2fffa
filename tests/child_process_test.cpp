// runInChild (core/child_process.h): what a child returns arrives whole, and a crash, an exception or an
// allocation without end there comes back as a status while the caller goes on.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/child_process.h"

namespace cs {
namespace {

TEST(ChildProcess, WhatTheChildReturnsArrivesWhole) {
  // More than a pipe holds at once, so the caller must read while the child writes.
  std::string big(3 << 20, '\0');
  for (size_t i = 0; i < big.size(); ++i) big[i] = char(i * 2654435761u >> 13);
  const ChildResult r = runInChild([&] { return big; }, 0, 0);
  ASSERT_TRUE(r.completed) << r.how;
  EXPECT_EQ(r.bytes, big);
  const ChildResult empty = runInChild([] { return std::string(); }, 0, 0);
  EXPECT_TRUE(empty.completed) << empty.how;
  EXPECT_TRUE(empty.bytes.empty());
}

TEST(ChildProcess, ACrashOrAnExceptionIsAStatusAndTheCallerGoesOn) {
  const ChildResult crash = runInChild([]() -> std::string {
    ::raise(SIGSEGV);
    return "never";
  }, 0, 0);
  EXPECT_FALSE(crash.completed);
  EXPECT_TRUE(crash.bytes.empty());
#if defined(__SANITIZE_ADDRESS__)  // it keeps its own fault handler, which reports and aborts
  EXPECT_TRUE(crash.how == "was stopped by signal 11 (segmentation fault)" || crash.how == "was stopped by signal 6 (abort)")
      << crash.how;
#else
  EXPECT_EQ(crash.how, "was stopped by signal 11 (segmentation fault)");
#endif
  const ChildResult aborted = runInChild([]() -> std::string { std::abort(); }, 0, 0);
  EXPECT_FALSE(aborted.completed);
  EXPECT_EQ(aborted.how, "was stopped by signal 6 (abort)");
  const ChildResult threw = runInChild([]() -> std::string { throw 42; }, 0, 0);
  EXPECT_FALSE(threw.completed);
  EXPECT_NE(threw.how.find("exception"), std::string::npos) << threw.how;
  EXPECT_TRUE(runInChild([] { return std::string("after"); }, 0, 0).completed);
}

TEST(ChildProcess, AnAllocationWithoutEndEndsTheChildNotTheCaller) {
  const ChildResult r = runInChild([]() -> std::string {
    std::vector<std::vector<char>> hold;
    for (;;) hold.emplace_back(size_t(256) << 20, char(1));  // 256 MiB at a time, each touched
  }, uint64_t(1) << 30, 0);
  EXPECT_FALSE(r.completed);
#if defined(__SANITIZE_ADDRESS__)  // its allocator reports the failed mapping and ends the process itself
  EXPECT_FALSE(r.how.empty());
#else
  EXPECT_EQ(r.how, "ran out of memory (it may use 1024 MiB)");
#endif
}

TEST(ChildProcess, AChildThatBlocksIsEndedAfterTwiceItsCpuBound) {
  const auto start = std::chrono::steady_clock::now();
  const ChildResult r = runInChild([]() -> std::string {
    ::pause();  // waits without using CPU, as on a lock no thread of the child will release
    return "never";
  }, 0, 1);
  EXPECT_FALSE(r.completed);
  EXPECT_EQ(r.how, "did not finish within 2 s");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(60));
}

}  // namespace
}  // namespace cs
