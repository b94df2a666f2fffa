// A small persistent thread pool for the CPU reference: parallelFor over index ranges on all hardware
// threads, workers kept alive across frames so a frame's ray stage does not pay thread creation.
// (std::thread rather than TBB: cs_reference links Embree and Threads only, not TBB itself.)
#pragma once
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace cs {

class ThreadPool {
 public:
  // threads = 0: std::thread::hardware_concurrency(). The calling thread works too, so threads - 1
  // workers are started. Every worker runs with FTZ/DAZ set (Embree's advice: denormals are slow).
  explicit ThreadPool(unsigned threads = 0);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  unsigned threadCount() const { return unsigned(workers_.size()) + 1; }

  // Calls fn(begin, end) over [0, count) in chunks of `grain`, on all threads, and returns when all
  // chunks are done. The calling thread runs with FTZ/DAZ for the duration and gets its MXCSR back.
  // The first exception thrown by fn is rethrown here (remaining chunks are skipped). Not reentrant.
  void parallelFor(size_t count, size_t grain, const std::function<void(size_t, size_t)>& fn);

 private:
  void workerLoop();
  void runChunks();

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  uint64_t generation_ = 0;   // bumped per parallelFor call; workers wait for a new one
  unsigned busy_ = 0;         // workers still inside the current call
  bool stop_ = false;
  // The current call (valid while busy_ > 0 or the caller is working).
  const std::function<void(size_t, size_t)>* fn_ = nullptr;
  size_t count_ = 0, grain_ = 1;
  std::atomic<size_t> next_{0};
  std::exception_ptr error_;
};

}  // namespace cs
