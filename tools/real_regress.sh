#!/usr/bin/env bash
# The real-data gate (issue 17): train the default model (the class map over
# Debian's Sweet Home 3D catalogs, fixed gates, no scorer), import the
# labelled real scans of data/real/, evaluate them, and compare the run with
# tests/baselines/real_set.json. Exit 1 when a gated metric got worse.
#   bash tools/real_regress.sh BUILD_DIR WORK_DIR
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${1:?usage: real_regress.sh BUILD_DIR WORK_DIR}"
work="${2:?usage: real_regress.sh BUILD_DIR WORK_DIR}"
workbench="$build_dir/workbench/workbench"
mkdir -p "$work"
echo "== train the default model (about 70 s on 2 cores)"
"$workbench" train --no-vote-net --catalog default --out "$work/model.fcm" --quiet
echo "== import the real scans"
rm -f "$work/real.db"
"$workbench" dataset import-real "$repo/data/real/labels.json" --out "$work/real.db" \
  --sheets "$work/sheets"
echo "== evaluate"
"$workbench" evaluate --model "$work/model.fcm" --db "$work/real.db" --split test --label ci --quiet
"$workbench" regress --db "$work/real.db" --baseline "$repo/tests/baselines/real_set.json"
