#!/usr/bin/env bash
# The main job: set up (tools/setup.sh), then render the built-in scene with the cone path, judged against
# the Embree reference on the same samples, and
# write the shaded image, mask, diff and results into out/. Extra arguments go to `coneshadow render`.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash tools/setup.sh
exec build/app/coneshadow render --method cone --out out "$@"
