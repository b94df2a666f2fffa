// The method registry: every shadow path plugs in here under its CLI name.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "app/cli.h"
#include "eval/method.h"

namespace cs {

std::vector<std::string> methodNames();
// The device-independent limits of the size settings (--traversal-memory, --rmsm-pool, --rmsm-page,
// --rmsm-max-res, --rmsm-analysis), checked when the arguments are parsed: UsageError naming the flag and
// what it allows. (What depends on the device, such as one storage binding, is found when the method is
// made.)
void checkSettings(const Options& options);
// Validates a method name and its settings before any heavy work; throws UsageError.
void checkMethod(const std::string& name, const Options& options);
// Throws UsageError for an unknown name or a setting the method does not take.
std::unique_ptr<ShadowMethod> makeMethod(const std::string& name, vk::Context* ctx, const Options& options);

}  // namespace cs
