// coneshadow: the command-line entry point (app/commands.h runMain).
#include "app/commands.h"

int main(int argc, char** argv) { return cs::runMain(argc, argv); }
