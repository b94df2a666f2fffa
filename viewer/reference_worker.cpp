// The viewer's reference worker: see reference_worker.h.
#include "viewer/reference_worker.h"

#include <exception>

#include "reference/embree_reference.h"

namespace cs::viewer {

ReferenceWorker::ReferenceWorker(const EpsilonPolicy& policy) : policy_(policy), thread_([this] { loop(); }) {}

ReferenceWorker::~ReferenceWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void ReferenceWorker::submit(ReferenceJob job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queued_ = std::move(job);
  }
  wake_.notify_all();
}

std::optional<ReferenceAnswer> ReferenceWorker::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<ReferenceAnswer> out = std::move(answer_);
  answer_.reset();
  return out;
}

uint64_t ReferenceWorker::busyWith() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queued_ ? queued_->generation : running_;
}

void ReferenceWorker::loop() {
  EmbreeReference embree;  // its device lives as long as the worker: no frame pays Embree's start
  for (;;) {
    ReferenceJob job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || queued_; });
      if (stop_) return;
      job = std::move(*queued_);
      queued_.reset();
      running_ = job.generation;
    }
    ReferenceAnswer a;
    a.generation = job.generation;
    try {
      FrameInput input;
      input.scene = job.scene.get();
      input.gbuffer = &job.gbuffer;
      input.light = job.light;
      input.epsilon = policy_.eps;
      input.camera = &job.camera;
      MethodOutput out = embree.run(input);
      a.visibility = std::move(out.visibility);
      a.referenceMs = out.totalMs;
      StageTime bandTime;
      a.band = embree.ambiguityBand(*job.scene, job.gbuffer, job.light, policy_, {}, &bandTime);
      a.bandMs = bandTime.ms;
    } catch (const std::exception& e) {
      a.failure = e.what();
    }
    std::lock_guard<std::mutex> lock(mutex_);
    answer_ = std::move(a);
    running_ = 0;
  }
}

}  // namespace cs::viewer
