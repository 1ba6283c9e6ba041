#!/usr/bin/env bash
# Memcheck pass for uninitialised reads and invalid accesses (ctest label
# 'slow': ctest -L slow -R memcheck). Runs a one-room `generate` and one
# `detect` under valgrind and fails on any error valgrind reports that the
# suppression file does not name. Valgrind hides AVX-512 from the program, so
# this also runs Embree's AVX2 kernels on any machine.
#
#   valgrind_memcheck.sh WORKBENCH SUPPRESSIONS SCRATCH_DIR [CATALOG]
set -euo pipefail
workbench="$1"
suppressions="$2"
dir="$3"
catalog="${4:-procedural:3}"

command -v valgrind > /dev/null || { echo "memcheck: valgrind is missing (apt-get install valgrind)"; exit 1; }
rm -rf "$dir"
mkdir -p "$dir"
export FURN_MESH_CACHE=off
unset FURN_EMBREE_CONFIG

# The model is trained natively: training is not what this pass checks.
"$workbench" train --no-vote-net --catalog "$catalog" --vocab kmeans --words 20 --azimuths 6 --quiet \
  --out "$dir/model.fcm"

memcheck=(valgrind --tool=memcheck --error-exitcode=99 --track-origins=yes --num-callers=40
          --leak-check=no --suppressions="$suppressions" --gen-suppressions=all)
status=0
run() {
  local name="$1"
  shift
  local start=$SECONDS
  if "${memcheck[@]}" --log-file="$dir/$name.log" "$workbench" "$@"; then
    echo "memcheck: $name clean ($((SECONDS - start)) s)"
  else
    local code=$?
    echo "memcheck: $name FAILED with exit code $code ($((SECONDS - start)) s); valgrind's log:"
    cat "$dir/$name.log"
    status=1
  fi
}
run generate generate --catalog "$catalog" --rooms 1 --frames 1 --seed 3 --quiet --out "$dir/one.db"
if [[ -f "$dir/one.db" ]]; then  # frame ids are room * frames + index: room 0's frame is 0
  run detect detect --model "$dir/model.fcm" --db "$dir/one.db" --frame 0 --quiet \
    --out "$dir/detections.json"
fi
exit $status
