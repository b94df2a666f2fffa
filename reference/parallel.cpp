// The CPU reference's threads on a TBB task arena: see parallel.h.
#include "reference/parallel.h"

#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>

namespace cs {

namespace {

// FTZ/DAZ on for whatever runs inside the scope, the thread's own mode back after it.
class FlushToZero {
 public:
  FlushToZero() : saved_(_mm_getcsr()) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
  ~FlushToZero() { _mm_setcsr(saved_); }
  FlushToZero(const FlushToZero&) = delete;
  FlushToZero& operator=(const FlushToZero&) = delete;

 private:
  unsigned saved_;
};

// Sets FTZ/DAZ on every worker that enters the arena (a worker thread's mode is its own). Not on the
// thread that calls parallelFor, which enters too: its mode is the caller's (a Python interpreter's
// numpy, say), set only while it works a chunk (FlushToZero) and given back after.
class FlushToZeroObserver : public tbb::task_scheduler_observer {
 public:
  explicit FlushToZeroObserver(tbb::task_arena& arena) : tbb::task_scheduler_observer(arena) { observe(true); }
  ~FlushToZeroObserver() override { observe(false); }
  void on_scheduler_entry(bool isWorker) override {
    if (!isWorker) return;
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
};

}  // namespace

struct ThreadPool::Arena {
  tbb::task_arena arena;
  std::unique_ptr<FlushToZeroObserver> observer;
  explicit Arena(unsigned threads) : arena(threads ? int(threads) : tbb::task_arena::automatic) {
    arena.initialize();
    observer = std::make_unique<FlushToZeroObserver>(arena);
  }
};

ThreadPool::ThreadPool(unsigned threads) : arena_(std::make_unique<Arena>(threads)) {}

ThreadPool::~ThreadPool() = default;

unsigned ThreadPool::threadCount() const { return unsigned(std::max(1, arena_->arena.max_concurrency())); }

void ThreadPool::parallelFor(size_t count, size_t grain, const std::function<void(size_t, size_t)>& fn) {
  if (count == 0) return;
  grain = std::max<size_t>(1, grain);
  arena_->arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, count, grain),
        [&](const tbb::blocked_range<size_t>& r) {
          FlushToZero ftz;  // the calling thread too, while it works a chunk
          fn(r.begin(), r.end());
        },
        tbb::simple_partitioner());
  });
}

}  // namespace cs
