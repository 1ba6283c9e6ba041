#!/usr/bin/env bash
# Protocol E (leave-models-out) of the learned detector at the default
# training budget, over several fold seeds: for each seed S a dataset of 60
# rooms x 4 frames whose targets are one fold's models (3 folds), then
# `crossval` trains a vote network per fold (2400 rooms x 10 epochs unless
# FURN_PE_FLAGS says otherwise) without that fold's models and evaluates it.
# A second decoding or option on the same fold models costs an evaluation
# only: crossval reuses a fold's model when its inputs are the same.
#
#   bash tools/protocol_e.sh build out/pe 1 2 3                  # train + evaluate
#   FURN_PE_EVAL="--centre-from peak" bash tools/protocol_e.sh build out/pe 1 2 3
#
# Each seed's summary lands in OUT/seed-S.txt (and a run in OUT/pe-S.db).
set -euo pipefail
build_dir="$1"
out_dir="$2"
shift 2
workbench="$build_dir/workbench/workbench"
mkdir -p "$out_dir"
for seed in "$@"; do
  db="$out_dir/pe-$seed.db"
  [[ -f "$db" ]] || "$workbench" generate --catalog default --rooms 60 --frames 4 --seed "2$seed" \
    --model-folds 3 --fold-seed "$seed" --quiet --out "$db"
  tag="${FURN_PE_TAG:-default}"
  # shellcheck disable=SC2086  # the flags are words on purpose
  "$workbench" crossval --db "$db" --work-dir "$out_dir/models-$seed" \
    --rooms-cache "$out_dir/rooms" ${FURN_PE_FLAGS:-} \
    ${FURN_PE_EVAL:-} --label "pe-$tag" --quiet | tee "$out_dir/seed-$seed-$tag.txt"
done
