// All-or-nothing output folders and the interrupt cleanup: see staged_dir.h.
#include "app/staged_dir.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <system_error>
#include <thread>
#include <vector>

#include "core/error.h"

namespace fs = std::filesystem;

namespace cs {

namespace {

// The live staging folders, removed by the interrupt thread.
std::mutex gLiveMutex;
std::set<std::string>& live() {
  static std::set<std::string> folders;
  return folders;
}

void track(const std::string& path) {
  std::lock_guard<std::mutex> lock(gLiveMutex);
  live().insert(path);
}

void untrack(const std::string& path) {
  std::lock_guard<std::mutex> lock(gLiveMutex);
  live().erase(path);
}

// A path made absolute and normal, without a trailing separator ("out/" and "out" are one folder).
fs::path normalPath(const std::string& p) {
  fs::path n = fs::absolute(fs::path(p)).lexically_normal();
  if (!n.has_filename() && n.has_parent_path() && n != n.root_path()) n = n.parent_path();
  return n;
}

constexpr const char* kMarkerHeader = "written by coneshadow: the next run into this folder replaces it as a whole";
constexpr const char* kEntryPrefix = "entry ";

// Both spellings of a path: as given (made absolute and normal) and with its links resolved.
bool within(const fs::path& inner, const fs::path& outer) {
  if (pathWithin(inner.string(), outer.string())) return true;
  std::error_code e1, e2;
  const fs::path a = fs::weakly_canonical(inner, e1), b = fs::weakly_canonical(outer, e2);
  return !e1 && !e2 && pathWithin(a.string(), b.string());
}

// The entries a marker lists; `legacy` when it lists none (a marker of an earlier version).
std::set<std::string> markerEntries(const fs::path& marker, bool& legacy) {
  std::ifstream in(marker);
  std::set<std::string> names;
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(kEntryPrefix, 0) == 0) names.insert(line.substr(std::char_traits<char>::length(kEntryPrefix)));
  legacy = names.empty();
  return names;
}

// The target may be replaced: it does not exist, or is a folder that is empty or that coneshadow wrote
// (its marker lists every entry in it), and it holds neither the current folder nor an input.
void checkReplaceable(const fs::path& target, const std::vector<std::string>& inputs) {
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(target, ec);
  if (ec || !fs::exists(st)) return;
  if (!fs::is_directory(st))
    throw Error("the output path exists and is not a folder", target.string(), "choose a new or empty folder");
  const fs::path cwd = fs::current_path(ec);
  if (!ec && within(cwd, target))
    throw Error("the output folder is the current folder or holds it, and a run replaces its output folder as a whole",
                target.string(), "choose a new folder outside the current one, e.g. --out results");
  for (const std::string& input : inputs)
    if (!input.empty() && within(fs::path(input), target))
      throw Error("the output folder holds the scene " + fs::path(input).filename().string() +
                      ", and a run replaces its output folder as a whole",
                  target.string(), "choose a new folder that does not hold the scene");
  if (fs::is_empty(target, ec) && !ec) return;
  const fs::path marker = target / kOutputMarker;
  if (!fs::is_regular_file(fs::symlink_status(marker, ec)))
    throw Error("the output folder holds files coneshadow did not write, and a run replaces its output folder as a whole",
                target.string(), "choose a new or empty folder");
  bool legacy = false;
  const std::set<std::string> written = markerEntries(marker, legacy);
  if (legacy) return;
  for (const fs::directory_entry& e : fs::directory_iterator(target, ec)) {
    const std::string name = e.path().filename().string();
    if (name != kOutputMarker && !written.count(name))
      throw Error("the output folder holds '" + name.substr(0, 60) +
                      "', which coneshadow did not write there, and a run replaces its output folder as a whole",
                  target.string(), "move that file out, or choose a new or empty folder");
  }
  if (ec) throw Error("cannot list the output folder: " + ec.message(), target.string(), "check permissions");
}

// The marker with the list of what the folder holds, written last into the staging folder.
void writeMarker(const fs::path& folder) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(folder, ec))
    if (e.path().filename() != kOutputMarker) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  std::ofstream marker(folder / kOutputMarker, std::ios::trunc);
  marker << kMarkerHeader << "\n";
  for (const std::string& n : names) marker << kEntryPrefix << n << "\n";
  marker.close();
  if (ec || !marker) throw Error("cannot write the output folder's marker", folder.string(), "check permissions and free space");
}

// Removes a folder that another thread may still be writing into: a few tries.
void removeTree(const std::string& path) {
  for (int attempt = 0; attempt < 5; ++attempt) {
    std::error_code ec;
    fs::remove_all(path, ec);
    if (!ec && !fs::exists(path, ec)) return;
  }
}

}  // namespace

bool pathWithin(const std::string& inner, const std::string& outer) {
  const fs::path a = normalPath(inner), b = normalPath(outer);
  auto ai = a.begin();
  for (auto bi = b.begin(); bi != b.end(); ++bi, ++ai)
    if (ai == a.end() || *ai != *bi) return false;
  return true;
}

StagedDir::StagedDir(const std::string& target, const std::vector<std::string>& inputs) : inputs_(inputs) {
  const fs::path t = normalPath(target);
  target_ = t.string();
  if (t == t.root_path()) throw Error("cannot replace the root folder with the output", target_, "choose a new folder");
  checkReplaceable(t, inputs_);
  std::error_code ec;
  fs::create_directories(t.parent_path(), ec);
  if (ec) throw Error("cannot create the output folder's parent: " + ec.message(), target_, "check the path and permissions");
  staging_ = (t.parent_path() / ("." + t.filename().string() + ".staging-" + std::to_string(::getpid()))).string();
  fs::remove_all(staging_, ec);
  track(staging_);
  fs::create_directory(staging_, ec);
  if (ec) {
    untrack(staging_);
    throw Error("cannot write beside the output folder: " + ec.message(), target_, "check permissions");
  }
  try {
    writeMarker(staging_);
  } catch (const Error&) {
    removeTree(staging_);
    untrack(staging_);
    throw;
  }
}

StagedDir::~StagedDir() {
  if (committed_) return;
  removeTree(staging_);
  untrack(staging_);
}

void StagedDir::commit() {
  const fs::path t(target_);
  writeMarker(staging_);
  checkReplaceable(t, inputs_);  // again: the target may have changed while the run worked
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(t, ec))) {
    if (std::rename(staging_.c_str(), target_.c_str()) != 0)
      throw Error("cannot move the output into place: " + std::string(std::strerror(errno)), target_);
  } else if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE) != 0) {
    if (errno != EINVAL && errno != ENOSYS)
      throw Error("cannot swap the output into place: " + std::string(std::strerror(errno)), target_);
    // A file system without the atomic exchange: the old folder aside, the new one in, the old one back
    // if that fails.
    const std::string aside = staging_ + ".old";
    if (std::rename(target_.c_str(), aside.c_str()) != 0)
      throw Error("cannot move the previous output aside: " + std::string(std::strerror(errno)), target_);
    if (std::rename(staging_.c_str(), target_.c_str()) != 0) {
      const std::string why = std::strerror(errno);
      std::rename(aside.c_str(), target_.c_str());
      throw Error("cannot move the output into place: " + why, target_);
    }
    removeTree(aside);
    committed_ = true;
    untrack(staging_);
    return;
  } else {
    removeTree(staging_);  // the exchange left the previous output here
  }
  committed_ = true;
  untrack(staging_);
}

void removeLiveStagingOnCrash() {
  std::unique_lock<std::mutex> lock(gLiveMutex, std::try_to_lock);
  if (!lock.owns_lock()) return;
  for (const std::string& path : live()) removeTree(path);
}

void installInterruptCleanup() {
  static std::once_flag once;
  std::call_once(once, [] {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGHUP);
    sigset_t previous;
    if (pthread_sigmask(SIG_BLOCK, &set, &previous) != 0) return;
    std::thread waiter;
    try {
      waiter = std::thread([set] {
        int sig = 0;
        while (sigwait(&set, &sig) != 0) {
        }
        {
          std::lock_guard<std::mutex> lock(gLiveMutex);
          for (const std::string& path : live()) removeTree(path);
        }
        const char text[] = "coneshadow: interrupted: the run's unfinished output was removed\n";
        [[maybe_unused]] ssize_t n = ::write(STDERR_FILENO, text, sizeof text - 1);
        std::_Exit(128 + sig);
      });
    } catch (const std::system_error& e) {
      // No thread to wait for the signals: unblock them again (an interrupt then ends the process as
      // usual) and say why, before the run has made anything.
      pthread_sigmask(SIG_SETMASK, &previous, nullptr);
      throw Error(std::string("could not start the thread that cleans up after an interrupt: ") + e.what(),
                  "interrupt cleanup", "the process may not start threads: raise its memory or thread limits (ulimit -v, -u)");
    }
    waiter.detach();
  });
}

}  // namespace cs
