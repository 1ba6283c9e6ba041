#!/usr/bin/env bash
# The README's cluster figure (issue 31): frames/s of `generate` and
# `evaluate` as one process and as an N-task Slurm array job on the one-node
# cluster of tools/slurm_local.sh, with the time of each stage of the array
# (submission to first task, tasks, final merge) for the projection to more
# nodes. As root; stops the cluster it started.
#
#   bash tools/cluster_throughput.sh WORKDIR MODEL [ROOMS] [FRAMES] [TASKS]
#
# MODEL: a trained .fcm (the evaluate half). Defaults: 24 rooms x 4 frames of
# the default catalog, 4 tasks of one CPU each. Results: WORKDIR/throughput.txt.
set -euo pipefail

work="${1:?usage: cluster_throughput.sh WORKDIR MODEL [ROOMS] [FRAMES] [TASKS]}"
model="$(realpath "${2:?a trained model file (.fcm)}")"
rooms="${3:-24}"
frames="${4:-4}"
tasks="${5:-4}"
here="$(cd "$(dirname "$0")/.." && pwd)"
workbench="${FURN_WORKBENCH:-$here/build/workbench/workbench}"
[ -x "$workbench" ] || { echo "cluster_throughput: no workbench at $workbench (build first)" >&2; exit 1; }
[ -f "$model" ] || { echo "cluster_throughput: $model: no such model file" >&2; exit 1; }

mkdir -p "$work"
work="$(realpath "$work")"
rm -rf "$work"/gen "$work"/eval "$work"/one.db "$work"/array.db "$work"/throughput.txt
bash "$here/tools/slurm_local.sh" start "$work/slurm" > /dev/null
trap 'bash "$here/tools/slurm_local.sh" stop "$work/slurm" > /dev/null' EXIT
export SLURM_CONF="$work/slurm/slurm.conf"

now() { date +%s.%N; }
mtime() { stat -c %.9Y "$1"; }
# Seconds from $1 to $2, 1 decimal.
span() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }
rate() { awk -v n="$1" -v a="$2" -v b="$3" 'BEGIN { printf "%.2f", n / (b - a) }'; }

# One line per array job: wall time, frames/s, then its stages from the job
# folder's status files (first task done, last task done, final done).
report_array() {
  local name="$1" dir="$2" start="$3" end="$4" n="$5" first last final
  first="$(for f in "$dir"/status/task-*.ok; do mtime "$f"; done | sort -n | head -1)"
  last="$(for f in "$dir"/status/task-*.ok; do mtime "$f"; done | sort -n | tail -1)"
  final="$(mtime "$dir/status/final.ok")"
  printf '%-9s %d-task array: %6.1f s, %6s frames/s (submit to first task done %s s, to last %s s; final step %s s)\n' \
    "$name" "$tasks" "$(span "$start" "$end")" "$(rate "$n" "$start" "$end")" \
    "$(span "$start" "$first")" "$(span "$start" "$last")" "$(span "$last" "$final")"
}

n=$((rooms * frames))
common="--catalog default --rooms $rooms --frames $frames --seed 3 --quiet"
{
  echo "cluster_throughput: $n frames ($rooms rooms x $frames), $tasks tasks of 1 CPU, $(nproc) CPUs, $(date -u +%FT%TZ)"
  a="$(now)"; "$workbench" generate $common --out "$work/one.db" > /dev/null; b="$(now)"
  printf '%-9s one process:    %6.1f s, %6s frames/s\n' generate "$(span "$a" "$b")" "$(rate "$n" "$a" "$b")"
  a="$(now)"
  "$workbench" generate $common --out "$work/array.db" --shards "$tasks" --cpus 1 --slurm --job-dir "$work/gen" > /dev/null
  "$workbench" jobs wait "$work/gen" --poll 0.2 --quiet > /dev/null
  b="$(now)"
  report_array generate "$work/gen" "$a" "$b" "$n"

  evaluate="evaluate --quiet --split all --model $model --db"
  a="$(now)"; "$workbench" $evaluate "$work/one.db" > /dev/null; b="$(now)"
  printf '%-9s one process:    %6.1f s, %6s frames/s\n' evaluate "$(span "$a" "$b")" "$(rate "$n" "$a" "$b")"
  a="$(now)"
  "$workbench" $evaluate "$work/array.db" --shards "$tasks" --cpus 1 --slurm --job-dir "$work/eval" > /dev/null
  "$workbench" jobs wait "$work/eval" --poll 0.2 --quiet > /dev/null
  b="$(now)"
  report_array evaluate "$work/eval" "$a" "$b" "$n"
  echo "dataset: $(du -h "$work/one.db" | cut -f1); shard files of evaluate: $(du -ch "$work"/eval/shard-*.json | tail -1 | cut -f1)"
} | tee "$work/throughput.txt"
