#!/usr/bin/env bash
# Quick start: install dependencies, build, and run the default scene into out/quickstart/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
build/bin/frichb run configs/quickstart_friction_oscillator.yaml -o out/quickstart
echo "quickstart: results in out/quickstart/ (response.csv, summary.json, response.png)"
