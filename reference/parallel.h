// The CPU reference's threads: parallelFor over index ranges in one TBB task arena (TBB is already the
// tasking system of Embree), its workers kept across frames, every worker running with FTZ/DAZ set
// (Embree's advice: denormals are slow) through a scheduler observer.
#pragma once
#include <cstddef>
#include <functional>
#include <memory>

namespace cs {

class ThreadPool {
 public:
  // threads = 0: all hardware threads.
  explicit ThreadPool(unsigned threads = 0);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  unsigned threadCount() const;

  // Calls fn(begin, end) over [0, count) in chunks of at most `grain`, on the arena's threads (the caller
  // joins in), and returns when all are done. Every thread runs the chunks with FTZ/DAZ set and gets its
  // own floating-point mode back afterwards. An exception thrown by fn is rethrown here (TBB cancels the
  // remaining chunks).
  void parallelFor(size_t count, size_t grain, const std::function<void(size_t, size_t)>& fn);

 private:
  struct Arena;
  std::unique_ptr<Arena> arena_;
};

}  // namespace cs
