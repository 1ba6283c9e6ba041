#!/usr/bin/env bash
# The sanitizer check (issue 21): builds the project with
# FURN_SANITIZE=address,undefined in its own build folder and runs the fast
# test suite under AddressSanitizer, LeakSanitizer and UndefinedBehaviorSanitizer
# (no recovery: any finding fails its test). About 25 minutes of build and 30
# of tests on 2 cores, so CI does not run it; run it before a release or after
# touching memory-heavy code:
#   bash tools/sanitize_check.sh [build-dir] [extra ctest args...]
# Also registered as the ctest label 'sanitize' of the normal build.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${1:-$repo/build-asan}"
shift || true
if [[ ! -f "$build_dir/build.ninja" ]]; then
  cmake -S "$repo" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DFURN_SANITIZE=address,undefined -DFURN_BUILD_BENCHMARKS=OFF
fi
cmake --build "$build_dir" -j 2
# Long end-to-end runs (slow, real) stay out: under the sanitizers they take hours.
exec ctest --test-dir "$build_dir" --output-on-failure -j 2 -L fast --timeout 1500 "$@"
