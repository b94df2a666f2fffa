// The CLI as a function: parse, dispatch, and turn every failure into one line on stderr and a
// documented exit code. Tests call it in-process, with methods they registered themselves.
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include "app/cli.h"
#include "app/commands.h"
#include "app/compare.h"
#include "app/results_table.h"
#include "core/error.h"

namespace cs {

int runMain(int argc, char** argv) {
  try {
    const Options options = parseArgs(argc, argv);
    if (options.command == "help" || options.command == "version") {
      std::cout << options.text;
      return kExitOk;
    }
    if (options.command == "results-table") return runResultsTable(options.folders, std::cout, options.hostCost);
    if (options.command == "devices") return runDevices(options);
    if (options.command == "info") return runInfo(options);
    if (options.command == "compare") return runCompare(options);
    if (options.command == "visibility") return runVisibility(options);
    return runRender(options);
  } catch (const UsageError& e) {
    std::cerr << "coneshadow: " << e.what() << "\n";
    return kExitUsage;
  } catch (const std::bad_alloc&) {
    std::cerr << "coneshadow: error: out of host memory (a host allocation failed) (lower the resolution, give the "
                 "cone path a --memory-budget, or raise the process's memory limit: ulimit -v)\n";
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "coneshadow: error: " << e.what() << "\n";
    return kExitFailure;
  }
}

}  // namespace cs
