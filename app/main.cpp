// coneshadow: the command-line entry point (app/commands.h runMain).
#include <cxxabi.h>
#include <execinfo.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>
#include <typeinfo>

#include "app/cli.h"
#include "app/commands.h"
#include "app/staged_dir.h"
#include "vk/context.h"

namespace {

void say(const char* text) { [[maybe_unused]] ssize_t n = ::write(STDERR_FILENO, text, std::strlen(text)); }

// An exception no handler takes -- thrown on a thread of a library (the driver's, Embree's pool) or out
// of a destructor while another unwinds -- ends the run with one line and the usual exit code, not an
// abort whose message needs the memory that ran out. Allocates nothing: write(2) alone, the message read
// by rethrowing the exception in flight (no new one). The frames that follow the line say where it was
// thrown, for a report.
[[noreturn]] void onUnhandledException() {
  const std::type_info* type = abi::__cxa_current_exception_type();
  const bool outOfMemory = type && (*type == typeid(std::bad_alloc) || *type == typeid(std::bad_array_new_length));
  const char* what = nullptr;  // the exception's own message, as the default handler finds it
  if (type && !outOfMemory) {
    try {
      throw;
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
  }
  say("coneshadow: error: ");
  if (outOfMemory) {
    say("out of host memory on a thread the run could not report it from (raise the process's memory limit: "
        "ulimit -v; or lower the resolution)\n");
  } else {
    say(what ? what : "an exception");
    say(" (thrown where nothing could report it, as ");
    say(type ? type->name() : "an unknown type");
    say("; where the process's memory is capped, a library's thread may have failed to start: raise the cap, "
        "ulimit -v; otherwise report it with the command line and the frames below)\n");
  }
  void* frames[48];
  const int n = backtrace(frames, 48);
  say("coneshadow: where it was thrown:\n");
  backtrace_symbols_fd(frames, n, STDERR_FILENO);
  cs::removeLiveStagingOnCrash();
  _exit(cs::kExitFailure);
}

}  // namespace

int main(int argc, char** argv) {
  {
    void* warm[1];
    backtrace(warm, 1);  // loads the unwinder now: the handler must not need memory to find it
  }
  std::set_terminate(&onUnhandledException);
  try {
    cs::installInterruptCleanup();  // before any thread starts: an interrupted run leaves no staging folder
  } catch (const std::exception& e) {
    std::cerr << "coneshadow: error: " << e.what() << "\n";
    return cs::kExitFailure;
  }
  cs::vk::setDriverCrashCleanup(&cs::removeLiveStagingOnCrash);  // nor does a driver crashing out of memory
  return cs::runMain(argc, argv);
}
