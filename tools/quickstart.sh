#!/usr/bin/env bash
# The README's two Quick start commands:
#   bash tools/quickstart.sh main   install what is missing, build, run the main job
#   bash tools/quickstart.sh test   install what is missing, build, run the test suite
# Works on a fresh Debian 12 machine as root (or with sudo). Idempotent: a second
# run installs nothing and rebuilds incrementally.
set -euo pipefail

mode="${1:-}"
if [[ "$mode" != main && "$mode" != test ]]; then
  echo "usage: bash tools/quickstart.sh main|test" >&2
  exit 2
fi

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
build_dir="${FURN_BUILD_DIR:-$repo/build}"

bash tools/install_deps.sh

# CI turns warnings into errors; users get warnings only.
werror=OFF
[[ "${CI:-}" == true ]] && werror=ON
if [[ ! -f "$build_dir/build.ninja" ]]; then
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFURN_WERROR="$werror"
else
  cmake -S . -B "$build_dir" -DFURN_WERROR="$werror" > /dev/null
fi
cmake --build "$build_dir" -j 2

if [[ "$mode" == test ]]; then
  # Foxglove's MCAP reader for rosbag_test's check of our MCAP files, when
  # node and the npm registry are there (the test says when it skips).
  if command -v npm > /dev/null && [[ ! -d tools/mcap_check/node_modules/@mcap/core ]]; then
    timeout 180 npm ci --prefix tools/mcap_check --no-audit --no-fund > /dev/null 2>&1 ||
      echo "quickstart: @mcap/core not installed (no npm registry?); rosbag_test skips its check"
  fi
  # The 'slow' label holds long end-to-end runs; run them with: ctest -L slow
  exec ctest --test-dir "$build_dir" --output-on-failure -j 2 -LE slow
fi
exec bash tools/main_job.sh "$build_dir"
