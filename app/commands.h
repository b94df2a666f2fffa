// The CLI's commands. Each returns an exit code; failures throw cs::Error (exit 1) or UsageError (exit 2).
#pragma once
#include "app/cli.h"
#include "core/scene.h"

namespace cs {

int runInfo(const Options& options);
int runRender(const Options& options);
int runDevices(const Options& options);

// SCENE argument → scene: empty or "builtin" is the built-in scene, anything else a glTF file.
Scene loadSceneArg(const std::string& arg, std::ostream& log);

}  // namespace cs
