#!/usr/bin/env bash
# The main job: sets up and builds when needed, then runs the system on the simulated sensor head's hard walk
# (tools/main_job.sh) and writes a report to out/latest/.
# Until every stage exists it runs the stages that do, and says which ones ran.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "${IPS_NO_SETUP:-0}" = 1 ] || ./tools/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
exec ./tools/main_job.sh "$@"
