// The method registry: every shadow path plugs in here under its CLI name.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "app/cli.h"
#include "eval/method.h"

namespace cs {

std::vector<std::string> methodNames();
// Validates a method name and its settings before any heavy work; throws UsageError.
void checkMethod(const std::string& name, const Options& options);
// Throws UsageError for an unknown name or a setting the method does not take.
std::unique_ptr<ShadowMethod> makeMethod(const std::string& name, vk::Context* ctx, const Options& options);

}  // namespace cs
