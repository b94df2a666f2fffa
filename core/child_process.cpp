// runInChild (child_process.h): fork, a pipe for the child's answer, limits set in the child before any
// work, and the child's end put into words.
#include "core/child_process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <new>

#include "core/error.h"

namespace cs {

namespace {

// Exit statuses of the child besides 0.
constexpr int kThrew = 70, kOutOfMemory = 71, kWriteFailed = 72;

// The caller's virtual size: the child's bound on its address space is this plus its allowance.
uint64_t virtualBytes() {
  FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  unsigned long long pages = 0;
  const int got = std::fscanf(f, "%llu", &pages);
  std::fclose(f);
  return got == 1 ? uint64_t(pages) * uint64_t(sysconf(_SC_PAGESIZE)) : 0;
}

[[noreturn]] void childMain(int out, const std::function<std::string()>& work, uint64_t memoryBytes, unsigned seconds) {
  // The caller's handlers are the caller's: a crash reporter, a sanitizer's or a fuzzer's report, an
  // interrupt flag. In the child a fault ends it, and the caller reads the signal.
  for (const int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGPIPE, SIGINT, SIGTERM}) ::signal(sig, SIG_DFL);
  const int devnull = ::open("/dev/null", O_WRONLY);
  if (devnull >= 0) ::dup2(devnull, STDERR_FILENO);
  // Over the caller's virtual size, which holds what a sanitizer reserved at start-up: the bound is on
  // what the child adds.
  if (memoryBytes) {
    const rlim_t most = rlim_t(virtualBytes() + memoryBytes);
    const rlimit bound{most, most};
    ::setrlimit(RLIMIT_AS, &bound);
  }
  if (seconds) {
    const rlimit cpu{rlim_t(seconds), rlim_t(seconds) + 1};
    ::setrlimit(RLIMIT_CPU, &cpu);
  }
  std::string answer;
  try {
    answer = work();
  } catch (const std::bad_alloc&) {
    ::_exit(kOutOfMemory);
  } catch (...) {
    ::_exit(kThrew);
  }
  for (size_t at = 0; at < answer.size();) {
    const ssize_t n = ::write(out, answer.data() + at, answer.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) ::_exit(kWriteFailed);
    at += size_t(n);
  }
  // _exit, not exit: the caller's atexit handlers and stdio buffers are the caller's, not the child's.
  ::_exit(0);
}

std::string signalWords(int sig) {
  std::string name;
  switch (sig) {
    case SIGSEGV: name = "segmentation fault"; break;
    case SIGBUS: name = "bus error"; break;
    case SIGABRT: name = "abort"; break;
    case SIGFPE: name = "arithmetic exception"; break;
    case SIGILL: name = "illegal instruction"; break;
    case SIGKILL: name = "killed, likely for memory"; break;
    case SIGXCPU: name = "out of CPU time"; break;
    default: name = "signal"; break;
  }
  return "was stopped by signal " + std::to_string(sig) + " (" + name + ")";
}

}  // namespace

uint64_t physicalMemoryBytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGESIZE);
  return pages > 0 && size > 0 ? uint64_t(pages) * uint64_t(size) : 0;
}

ChildResult runInChild(const std::function<std::string()>& work, uint64_t memoryBytes, unsigned seconds) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw Error(std::string("cannot create a pipe: ") + std::strerror(errno), "reader process", "free file descriptors");
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(std::string("cannot start a reader process: ") + std::strerror(err), "reader process", "free processes or memory");
  }
  if (pid == 0) {
    ::close(fds[0]);
    childMain(fds[1], work, memoryBytes, seconds);
  }
  ::close(fds[1]);
  ChildResult result;
  char buffer[1 << 16];
  // A child blocked without using CPU (a lock some other thread of the caller held at the fork) meets
  // no CPU bound: the caller waits twice that long in wall-clock time, then ends it.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2 * uint64_t(seconds));
  bool overdue = false;
  for (;;) {
    if (seconds) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      pollfd ready{fds[0], POLLIN, 0};
      const int polled = left.count() > 0 ? ::poll(&ready, 1, int(std::min<int64_t>(left.count(), 1 << 30))) : 0;
      if (polled < 0 && errno == EINTR) continue;
      if (polled == 0) {
        ::kill(pid, SIGKILL);
        overdue = true;
        break;
      }
    }
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n > 0) {
      result.bytes.append(buffer, size_t(n));
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      break;
    }
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      result.how = std::string("could not be waited for: ") + std::strerror(errno);
      return result;
    }
  }
  if (overdue) {
    result.how = "did not finish within " + std::to_string(2 * uint64_t(seconds)) + " s";
  } else if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
    result.completed = true;
  } else if (WIFEXITED(status)) {
    switch (WEXITSTATUS(status)) {
      case kOutOfMemory:
        result.how = "ran out of memory";
        if (memoryBytes) result.how += " (it may use " + std::to_string(memoryBytes >> 20) + " MiB)";
        break;
      case kThrew: result.how = "failed with an unexpected exception"; break;
      case kWriteFailed: result.how = "could not send its result"; break;
      default: result.how = "stopped with exit status " + std::to_string(WEXITSTATUS(status)); break;
    }
  } else if (WIFSIGNALED(status)) {
    result.how = signalWords(WTERMSIG(status));
  } else {
    result.how = "ended in an unknown way";
  }
  if (!result.completed) result.bytes.clear();
  return result;
}

}  // namespace cs
