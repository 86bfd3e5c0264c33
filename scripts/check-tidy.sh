#!/usr/bin/env bash
# Runs clang-tidy (checks in .clang-tidy, warnings as errors) over the project's sources,
# using build/compile_commands.json from scripts/build.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
[ -f build/compile_commands.json ] || { echo "check-tidy: run scripts/build.sh first" >&2; exit 1; }
files=$(git ls-files 'core/*.cpp' 'contact_laws/*.cpp' 'structures/*.cpp')
jobs=$(nproc 2>/dev/null || echo 2)
# shellcheck disable=SC2086
printf '%s\n' $files | xargs -P "$jobs" -n 4 clang-tidy -p build --quiet \
  --extra-arg=-Wno-unknown-warning-option 2>&1 | sed '/warnings generated/d'
echo "check-tidy: $(echo "$files" | wc -l) files clean"
