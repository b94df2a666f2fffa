#!/usr/bin/env bash
# The main job: set up (tools/setup.sh), then render the built-in scene with the Embree reference and
# write the shaded image, mask, diff and results into out/. Extra arguments go to `coneshadow render`.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash tools/setup.sh
exec build/app/coneshadow render --out out "$@"
