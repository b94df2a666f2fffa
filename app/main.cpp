// coneshadow: the command-line entry point (app/commands.h runMain).
#include "app/commands.h"
#include "app/staged_dir.h"
#include "vk/context.h"

int main(int argc, char** argv) {
  cs::installInterruptCleanup();  // before any thread starts: an interrupted run leaves no staging folder
  cs::vk::setDriverCrashCleanup(&cs::removeLiveStagingOnCrash);  // nor does a driver crashing out of memory
  return cs::runMain(argc, argv);
}
