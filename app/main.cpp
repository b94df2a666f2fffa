// coneshadow: the command-line entry point. Errors end as one line on stderr and a documented exit code.
#include <iostream>
#include <string>
#include <vector>

#include "app/cli.h"
#include "app/commands.h"
#include "app/compare.h"
#include "app/results_table.h"
#include "core/error.h"

int main(int argc, char** argv) {
  // results-table takes folders only, no options.
  const bool resultsTable = argc > 1 && std::string(argv[1]) == "results-table";
  cs::Options options;
  try {
    if (!resultsTable) options = cs::parseArgs(argc, argv);
  } catch (const cs::UsageError& e) {
    std::cerr << "coneshadow: " << e.what() << "\n";
    return cs::kExitUsage;
  }
  try {
    if (resultsTable) return cs::runResultsTable(std::vector<std::string>(argv + 2, argv + argc), std::cout);
    if (options.command == "help") {
      std::cout << cs::usageText();
      return cs::kExitOk;
    }
    if (options.command == "devices") return cs::runDevices(options);
    if (options.command == "info") return cs::runInfo(options);
    if (options.command == "compare") return cs::runCompare(options);
    return cs::runRender(options);
  } catch (const cs::UsageError& e) {
    std::cerr << "coneshadow: " << e.what() << "\n";
    return cs::kExitUsage;
  } catch (const cs::Error& e) {
    std::cerr << "coneshadow: error: " << e.what() << "\n";
    return cs::kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "coneshadow: error: " << e.what() << "\n";
    return cs::kExitFailure;
  }
}
