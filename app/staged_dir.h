// All-or-nothing output folders. A command writes into a staging folder beside its target
// (<parent>/.<name>.staging-<pid>) and, once everything is written, puts it in the target's place in one
// step: a rename when the target does not exist, else an atomic exchange of the two folders
// (renameat2 RENAME_EXCHANGE) after which the old contents are removed. A reader sees the old folder or
// the new one, never a mix, and a run replaces its folder's previous results rather than adding to them.
//
// Because the target is replaced as a whole, nothing is replaced unless coneshadow's marker says it wrote
// it: an existing target must be an empty folder, or hold the marker file kOutputMarker, which lists the
// entries the run wrote, and nothing else. A folder whose marker lists no entries (earlier versions) is
// taken as coneshadow's. Any other folder is refused, before the run writes anything and again at commit.
// A target may not be the current folder or hold it, nor hold any of the run's inputs (the scene).
//
// SIGINT, SIGTERM and SIGHUP remove every live staging folder before the process exits with 128 + the
// signal's number (installInterruptCleanup: the signals are blocked in every thread and one thread waits
// for them, so the cleanup runs outside a signal handler).
#pragma once
#include <string>
#include <vector>

namespace cs {

inline constexpr const char* kOutputMarker = ".coneshadow-output";

class StagedDir {
 public:
  // `inputs`: files the run reads (the scene); the target may not hold any of them.
  explicit StagedDir(const std::string& target, const std::vector<std::string>& inputs = {});
  ~StagedDir();  // removes the staging folder unless committed
  StagedDir(const StagedDir&) = delete;
  StagedDir& operator=(const StagedDir&) = delete;

  const std::string& path() const { return staging_; }  // where to write
  const std::string& target() const { return target_; }
  void commit();  // puts the staging folder in the target's place; throws cs::Error on failure

 private:
  std::string target_, staging_;
  std::vector<std::string> inputs_;
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
