#!/usr/bin/env bash
# NYU Depth V2's labelled frames as a real validation set, on this machine
# only (their licence is research use: nothing of them enters the repo).
#
#   bash tools/fetch_nyu.sh [--out DIR] [--max-frames N] [--source CHECKOUT] [--splits FILE]
#
# 1. fetches, pinned by commit and checksum, the public repository
#    markshih91/refinenet_pytorch (data/nyu_depths, nyu_labels40, nyu_images:
#    the 1449 labelled frames as 8-bit PNGs) and NYU's official split file
#    (utils/splits.mat of cleinc/bts);
# 2. converts the official train split only (`dataset convert-nyu`; the
#    held-out ranges 1330-1350 and 1400-1420 are never converted);
# 3. imports it as a dataset (`dataset import-real`) with label sheets and
#    checks its floors (`dataset floors`).
# Then: workbench evaluate --db DIR/nyu-train.db --model M --split test
#
# --source and --splits take copies fetched by other means (no network).
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
workbench="${FURN_WORKBENCH:-$repo/build/workbench/workbench}"
out="${FURN_NYU_OUT:-$repo/build/nyu}"
cache="${FURN_NYU_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/furnidet/nyu}"
source_dir="" splits="" max_frames=0

while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --max-frames) max_frames="$2"; shift 2 ;;
    --source) source_dir="$2"; shift 2 ;;
    --splits) splits="$2"; shift 2 ;;
    *) echo "fetch_nyu.sh: unknown argument '$1' (see the header of tools/fetch_nyu.sh)" >&2; exit 2 ;;
  esac
done

readonly kFramesRepo=https://github.com/markshih91/refinenet_pytorch
readonly kFramesCommit=109cc25300c5c545c7b732b2f4daa97b0755468b
readonly kSplitsUrl=https://raw.githubusercontent.com/cleinc/bts/d1ed7cafa0a666d85ce6c8840d3626aa902ae945/utils/splits.mat
readonly kSplitsSha256=6e081404491a8bfba2f066beaa9713ef6046f9007aa5f799f2a350506a580cee

[[ -x "$workbench" ]] || { echo "fetch_nyu.sh: $workbench is not built (bash tools/quickstart.sh test)" >&2; exit 1; }
mkdir -p "$cache"

if [[ -z "$source_dir" ]]; then
  source_dir="$cache/refinenet_pytorch"
  if [[ ! -d "$source_dir/data/nyu_depths" ]]; then
    echo "fetching the labelled frames ($kFramesRepo at ${kFramesCommit:0:7}, about 120 MB)"
    rm -rf "$source_dir.partial"
    git init -q "$source_dir.partial"
    git -C "$source_dir.partial" fetch -q --depth 1 "$kFramesRepo" "$kFramesCommit"
    git -C "$source_dir.partial" checkout -q FETCH_HEAD -- data/nyu_depths data/nyu_labels40 data/nyu_images
    mv "$source_dir.partial" "$source_dir"
  fi
fi
if [[ -z "$splits" ]]; then
  splits="$cache/splits.mat"
  if [[ ! -f "$splits" ]]; then
    echo "fetching NYU's official split (splits.mat)"
    curl -fsSL -o "$splits.partial" "$kSplitsUrl"
    mv "$splits.partial" "$splits"
  fi
fi
echo "$kSplitsSha256  $splits" | sha256sum --check --quiet - ||
  { echo "fetch_nyu.sh: $splits is not NYU's splits.mat (sha256 differs)" >&2; exit 1; }

mkdir -p "$out"
rm -rf "$out/nyu-train" "$out/nyu-train.db" "$out/sheets"
"$workbench" dataset convert-nyu --source "$source_dir" --splits "$splits" --out "$out/nyu-train" \
  --max-frames "$max_frames" --overlays
"$workbench" dataset import-real "$out/nyu-train/labels.json" --out "$out/nyu-train.db" \
  --sheets "$out/sheets"
"$workbench" dataset floors "$out/nyu-train.db" | tee "$out/floors.txt"
echo "real validation set: $out/nyu-train.db (overlays in $out/nyu-train/overlays, sheets in $out/sheets)"
