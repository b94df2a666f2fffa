// coneshadow: the command-line entry point. Errors end as one line on stderr and a documented exit code.
#include <iostream>

#include "app/cli.h"
#include "app/commands.h"
#include "app/compare.h"
#include "core/error.h"

int main(int argc, char** argv) {
  cs::Options options;
  try {
    options = cs::parseArgs(argc, argv);
  } catch (const cs::UsageError& e) {
    std::cerr << "coneshadow: " << e.what() << "\n";
    return cs::kExitUsage;
  }
  try {
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
