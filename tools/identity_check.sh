#!/usr/bin/env bash
# The same small end-to-end run on the procedural catalog (generate, train,
# evaluate, report, crossval with its scorer, a scored model, detect with
# debug PNGs, the real set, exports), the same on the learned path (a small
# one-thread vote-net training, evaluate, detect --explain with its debug
# folder, fused detection, crossval with vote nets), then a digest of everything it made
# (tools/identity_digest.py). A refactoring must leave the digest unchanged:
#   bash tools/identity_check.sh BUILD_BEFORE before/ > before.txt
#   bash tools/identity_check.sh BUILD_AFTER after/ > after.txt
#   diff before.txt after.txt
# (BUILD is a build folder, or a folder holding a copied workbench binary.)
set -euo pipefail
# The vote network's reference arithmetic (auto would be bf16 on a CPU with
# AMX-BF16, and builds before the option knew only float).
export FURN_NETWORK_PRECISION="${FURN_NETWORK_PRECISION:-fp32}"
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$1"
out="$2"
wb="$build/workbench/workbench"
[[ -x "$wb" ]] || wb="$build/workbench"
rm -rf "$out"
mkdir -p "$out"
cd "$out"
run() { "$wb" "$@" > /dev/null 2>> run.log; }
run generate --catalog procedural --rooms 6 --frames 3 --seed 1 --out d.db --quiet
run generate --catalog procedural --rooms 9 --frames 2 --seed 2 --model-folds 3 --out cv.db --quiet
run train --no-vote-net --catalog procedural --out m.fcm --quiet
run evaluate --model m.fcm --db d.db --split all --quiet
run crossval --no-vote-net --db cv.db --work-dir cvm --quiet
run train --no-vote-net --catalog procedural --scorer cvm/scorer.yml --out ms.fcm --quiet
run evaluate --model ms.fcm --db d.db --split test --quiet
run evaluate --model ms.fcm --db cv.db --split all --max-frames 6 --quiet
run report --db d.db --out report
"$wb" detect --model ms.fcm --db d.db --frame 2 --debug-dir detect --explain --out detect.json \
  > /dev/null 2> explain.txt
run dataset import-real "$repo/data/real/labels.json" --out real.db --sheets sheets
run evaluate --model ms.fcm --db real.db --split test --quiet
run dataset export d.db --format rosbag --out d.bag --split test 2>/dev/null || true
run dataset export d.db --format bop --out bop
run dataset export d.db --format pcd --out pcd
# The learned path (the default): vote nets trained on one torch thread.
vote_net=(--vote-frames 2 --vote-epochs 2 --vote-threads 1)
run train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 6 "${vote_net[@]}" \
  --vote-rooms 8 --out ml.fcm --quiet
run evaluate --model ml.fcm --db d.db --split all --quiet
run evaluate --model ml.fcm --db real.db --split test --quiet
"$wb" detect --model ml.fcm --db d.db --frame 2 --debug-dir detect_learned --explain \
  --out detect_learned.json > /dev/null 2> explain_learned.txt
run detect --model ml.fcm --db d.db --frame 4 --fuse --out detect_fused.json
run crossval "${vote_net[@]}" --vote-rooms 3 --db cv.db --work-dir cvl --quiet
run report --db d.db --out report_learned
rm -rf cvm/*.partial cvl/*.partial
python3 "$repo/tools/identity_digest.py" "$out"
grep -v "ms\b" explain.txt | sha256sum | sed 's/^/explain /'
grep -v "ms\b" explain_learned.txt | sha256sum | sed 's/^/explain_learned /'
