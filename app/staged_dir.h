// All-or-nothing output folders. A command writes into a staging folder beside its target
// (<parent>/.<name>.staging-<pid>) and, once everything is written, puts it in the target's place in one
// step: a rename when the target does not exist, else an atomic exchange of the two folders
// (renameat2 RENAME_EXCHANGE) after which the old contents are removed. A reader sees the old folder or
// the new one, never a mix, and a run replaces its folder's previous results rather than adding to them.
//
// Because the target is replaced as a whole, an existing target must be empty or written by coneshadow
// (it holds the marker file kOutputMarker, or the results.json or meta.json of an earlier version); any
// other folder is refused when the StagedDir is made, before the run writes anything.
//
// SIGINT, SIGTERM and SIGHUP remove every live staging folder before the process exits with 128 + the
// signal's number (installInterruptCleanup: the signals are blocked in every thread and one thread waits
// for them, so the cleanup runs outside a signal handler).
#pragma once
#include <string>

namespace cs {

inline constexpr const char* kOutputMarker = ".coneshadow-output";

class StagedDir {
 public:
  explicit StagedDir(const std::string& target);
  ~StagedDir();  // removes the staging folder unless committed
  StagedDir(const StagedDir&) = delete;
  StagedDir& operator=(const StagedDir&) = delete;

  const std::string& path() const { return staging_; }  // where to write
  const std::string& target() const { return target_; }
  void commit();  // puts the staging folder in the target's place; throws cs::Error on failure

 private:
  std::string target_, staging_;
  bool committed_ = false;
};

// True when `inner` is `outer` or lies inside it (both made absolute and normal first).
bool pathWithin(const std::string& inner, const std::string& outer);

// Blocks SIGINT, SIGTERM and SIGHUP in the calling thread (and so in every thread it starts later) and
// starts the thread that cleans up on them. Call first thing in main, before any thread exists; calls
// after the first do nothing.
void installInterruptCleanup();
// Removes every live staging folder, if no other thread is changing the list: what a Vulkan driver
// crash runs before the process exits (vk::setDriverCrashCleanup); best effort.
void removeLiveStagingOnCrash();

}  // namespace cs
