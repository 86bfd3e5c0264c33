#!/usr/bin/env bash
# Install dependencies, build with warnings as errors, and run the test suite with ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh -DFRICHB_WARNINGS_AS_ERRORS=ON
jobs=$(nproc 2>/dev/null || echo 2)
ctest --test-dir build --output-on-failure -j"$jobs" -LE long
