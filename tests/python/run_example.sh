#!/usr/bin/env bash
# The example script end to end on a small procedural dataset: it must print
# its detections and write a PNG. Args: source dir, work dir, workbench, python.
set -euo pipefail
source_dir=$1 work=$2 workbench=$3 python=$4
rm -rf "$work" && mkdir -p "$work"
"$workbench" generate --catalog procedural:4 --rooms 3 --frames 2 --seed 7 --quiet --out "$work/s.db"
"$workbench" train --no-vote-net --catalog procedural:4 --azimuths 4 --words 20 --vocab kmeans --quiet \
  --out "$work/m.fcm"
"$python" "$source_dir/examples/detect_in_frame.py" "$work/s.db" "$work/m.fcm" \
  --out "$work/frame.png" | tee "$work/stdout.txt"
grep -q "detections in" "$work/stdout.txt"
# A real PNG of the figure's size (1170 x 450 at 90 dpi).
"$python" -c "import matplotlib.image as i, sys; a = i.imread(sys.argv[1]); assert a.shape[:2] == (450, 1170), a.shape" "$work/frame.png"
