// The CLI's commands. Each returns an exit code; failures throw cs::Error (exit 1) or UsageError (exit 2).
#pragma once
#include "app/cli.h"
#include "core/scene.h"

namespace cs {

// The whole CLI: parses argv, runs the command, prints errors; returns the exit code.
int runMain(int argc, char** argv);
int runInfo(const Options& options);
int runRender(const Options& options);
int runDevices(const Options& options);
// visibility: the samples of a file from 1..L lights through the cone engine (app/visibility.cpp).
int runVisibility(const Options& options);

// SCENE of the command line: the built-in scene, a glTF file, or a BART .aff file at --time.
Scene loadSceneArg(const Options& options, std::ostream& log);
bool isAffFile(const std::string& path);

}  // namespace cs
