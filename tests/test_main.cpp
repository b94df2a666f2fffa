// Test entry point. The shared Vulkan context runs with validation on; any validation message becomes a
// failure of the test that was running when the layer printed it.
#include <cstdlib>

#include <gtest/gtest.h>

#include "tests/test_context.h"

namespace cs::test {

vk::Context& context() {
  static std::unique_ptr<vk::Context> ctx = [] {
    vk::ContextOptions options;
    options.validation = true;
    options.quiet = true;
    if (const char* d = std::getenv("CONESHADOW_DEVICE")) options.device = d;
    auto c = vk::createContext(options);
    c->onValidationMessage = [](const std::string& m) { ADD_FAILURE() << "Vulkan validation: " << m; };
    return c;
  }();
  return *ctx;
}

}  // namespace cs::test

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
