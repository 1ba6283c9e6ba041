#!/usr/bin/env bash
# The main job, end to end with what exists so far: import the default catalog
# (the repo's class map over Debian's Sweet Home 3D catalogs), print its summary,
# draw every classified model on a contact sheet, render one model as a Kinect
# v1 sees it, generate a labelled synthetic dataset (FURN_ROOMS rooms), run
# protocol E (leave-models-out: 3 folds of the CAD models, each trained
# without its fold and evaluated on rooms of its fold only) for the learned
# detector and for the codebook with a hypothesis scorer learnt per fold,
# train the default model (vocabulary, shape model, the scorer protocol E
# learnt, the vote network and its operating point), evaluate detection on the test split (a run in the
# dataset, and its HTML report), tune the learned detector's options, and detect
# in one frame. Prints the time of the long stages; every stage longer than a
# minute shows its progress (a bar on a terminal, a line at least every minute
# in a log).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${1:-$repo/build}"
out_dir="${FURN_OUT_DIR:-$repo/out}"
workbench="$build_dir/workbench/workbench"
mkdir -p "$out_dir"
job_start=$SECONDS

echo "== catalog: import every classified model of the default catalog"
"$workbench" catalog list --catalog default --load
"$workbench" catalog list --catalog default --load --json --quiet > "$out_dir/catalog.json"
echo "== catalog: contact sheet"
"$workbench" catalog sheet --catalog default --out "$out_dir/catalog.png" --quiet
echo "== render: the first classified model as ideal and noisy Kinect v1 depth"
"$workbench" render --catalog default --out "$out_dir/render" --quiet
echo "== generate: a labelled synthetic dataset from the default catalog (resumes if present)"
"$workbench" generate --catalog default --rooms "${FURN_ROOMS:-24}" --frames 4 --seed 1 --out "$out_dir/synth.db"
echo "== dataset: summary and contact sheet"
"$workbench" dataset info "$out_dir/synth.db"
"$workbench" dataset preview "$out_dir/synth.db" --out "$out_dir/synth_preview.png" --frames 12
echo "== crossval: protocol E, leave-models-out (3 folds of the CAD models; each fold's detector is"
echo "   trained without the fold's models and evaluated on rooms of the fold's models only)."
echo "   The learned detector (the default): a vote network per fold, at a budget this job can"
echo "   afford (${FURN_PE_VOTE_ROOMS:-150} rooms x ${FURN_PE_VOTE_EPOCHS:-10} epochs; the default model trains 2400 x 10)"
stage_start=$SECONDS
"$workbench" generate --catalog default --rooms "${FURN_CROSSVAL_ROOMS:-45}" --frames 4 --seed 2 \
  --model-folds 3 --quiet --out "$out_dir/crossval.db"
"$workbench" crossval --db "$out_dir/crossval.db" --work-dir "$out_dir/crossval_models" \
  --vote-rooms "${FURN_PE_VOTE_ROOMS:-150}" --vote-epochs "${FURN_PE_VOTE_EPOCHS:-10}" \
  | tee "$out_dir/crossval.txt"
"$workbench" report --db "$out_dir/crossval.db" --out "$out_dir/crossval_report"
echo "== crossval: the codebook (the paper's path, with a hypothesis scorer learnt per fold from"
echo "   the other folds' rooms) on the same folds"
"$workbench" crossval --no-vote-net --db "$out_dir/crossval.db" \
  --work-dir "$out_dir/crossval_codebook" | tee "$out_dir/crossval_codebook.txt"
"$workbench" report --db "$out_dir/crossval.db" --out "$out_dir/crossval_codebook_report"
echo "   (protocol E took $((SECONDS - stage_start)) s)"
echo "== train: part vocabulary and shape model from virtual scans of the catalog, with the"
echo "   hypothesis scorer crossval learnt from every fold, and the learned vote map (a CNN"
echo "   trained on rooms generated from the catalog; detection votes with it)"
stage_start=$SECONDS
"$workbench" train --catalog default --scorer "$out_dir/crossval_codebook/scorer.yml" \
  --out "$out_dir/model.fcm"
echo "   (training took $((SECONDS - stage_start)) s)"
"$workbench" model info "$out_dir/model.fcm"
echo "== evaluate: detection over the test split, stored as a run; then its report"
"$workbench" evaluate --model "$out_dir/model.fcm" --db "$out_dir/synth.db" --split test --quiet \
  | tee "$out_dir/evaluate.txt"
"$workbench" report --db "$out_dir/synth.db" --out "$out_dir/report"
echo "== tune: the learned detector's options on the val split (the model's vote network picks"
echo "   data/tune_learned_space.json: least heat, suppression, maxima per class, the fit), best"
echo "   checked on test"
"$workbench" tune --catalog default --db "$out_dir/synth.db" --strategy grid --trials 8 \
  --model "$out_dir/model.fcm" --work-dir "$out_dir/tune_work" --out "$out_dir/tune"
echo "== real scans: the labelled real set (data/real), evaluated as a run of its own, its report;"
echo "   the sensor model's noise against the real frames; history of synthetic and real runs"
labels="$repo/data/real/labels.json"
if [[ ! -f "$out_dir/real.db" || "$labels" -nt "$out_dir/real.db" ]]; then
  rm -f "$out_dir/real.db"
  "$workbench" dataset import-real "$labels" --out "$out_dir/real.db" --sheets "$out_dir/real_sheets"
fi
"$workbench" evaluate --model "$out_dir/model.fcm" --db "$out_dir/real.db" --split test --label real \
  --quiet | tee "$out_dir/real.txt"
"$workbench" report --db "$out_dir/real.db" --out "$out_dir/real_report"
"$workbench" dataset noise "$out_dir/real.db" | tee "$out_dir/noise.txt"
"$workbench" history --db "$out_dir/synth.db" --db "$out_dir/real.db" --out "$out_dir/history"
echo "== detect: furniture in one frame of the dataset, with the debug PNGs"
"$workbench" detect --model "$out_dir/model.fcm" --db "$out_dir/synth.db" --frame 8 \
  --out "$out_dir/detect/detections.json" --debug-dir "$out_dir/detect" --timings
echo "== ROS and Python: the test split as a ROS bag, detection over the bag with markers written"
echo "   back, and the Python example on one frame"
"$workbench" dataset export "$out_dir/synth.db" --format rosbag --split test --out "$out_dir/synth_test.bag"
"$workbench" detect --model "$out_dir/model.fcm" --bag "$out_dir/synth_test.bag" \
  --topic /camera/depth/image_raw --out "$out_dir/synth_test_bag.jsonl" \
  --out-bag "$out_dir/synth_test_marked.bag"
# The same as a ROS 2 bag folder (no .bag: rosbag2's SQLite storage), with
# markers and vision_msgs/Detection3DArray written back.
"$workbench" dataset export "$out_dir/synth.db" --format rosbag --split test --out "$out_dir/synth_test_ros2"
"$workbench" detect --model "$out_dir/model.fcm" --bag "$out_dir/synth_test_ros2" \
  --topic /camera/depth/image_raw --out "$out_dir/synth_test_ros2.jsonl" \
  --out-bag "$out_dir/synth_test_ros2_marked"
if [[ -d "$build_dir/python/furnidet" ]]; then
  PYTHONPATH="$build_dir/python" MPLBACKEND=Agg /usr/bin/python3 "$repo/examples/detect_in_frame.py" \
    "$out_dir/synth.db" "$out_dir/model.fcm" --out "$out_dir/python_frame.png"
fi
echo
echo "main job done:"
echo "  $out_dir/catalog.json   listing of the classified models"
echo "  $out_dir/catalog.png    contact sheet of the classified models"
echo "  $out_dir/render/        depth/id PNGs, organized PCDs, preview.png (ideal | Kinect v1)"
echo "  $out_dir/synth.db       labelled synthetic Kinect frames (SQLite; see 'workbench dataset')"
echo "  $out_dir/synth_preview.png  contact sheet: noisy depth with ground-truth boxes"
echo "  $out_dir/model.fcm      trained model (see 'workbench model info', 'workbench eval-parts')"
echo "  $out_dir/detect/        detections.json, debug PNGs (heat, votes, boxes, top-down) and"
echo "                           scene.html, the frame in 3-D (open it in a browser, offline)"
echo "  $out_dir/report/index.html  evaluation report of the test split (open it in a browser;"
echo "                           each gallery frame links its 3-D view)"
echo "  $out_dir/tune/index.html    tune report: trials ranked, parameter effects, best_options.json"
echo "  $out_dir/crossval_report/index.html  leave-models-out report (protocol E, learned), a report per fold"
echo "  $out_dir/crossval_codebook_report/index.html  the same for the codebook"
echo "  $out_dir/real.db, real_report/index.html, real_sheets/  the labelled real scans, their run and labels"
echo "  $out_dir/history/history.html  every run of synth.db and real.db, side by side"
echo "  $out_dir/synth_test.bag, synth_test_marked.bag  the test split as a ROS bag, and with detections"
echo "  $out_dir/synth_test_ros2/, synth_test_ros2_marked/  the same as ROS 2 bag folders"
echo "  $out_dir/python_frame.png  the Python example's plot of one test frame"
echo
echo "headline metrics, models seen in training (test split):"
cat "$out_dir/evaluate.txt"
echo
echo "headline metrics, models never seen in training (protocol E, the figure that matters),"
echo "the learned detector (vote networks at this job's reduced budget):"
cat "$out_dir/crossval.txt"
echo
echo "the codebook (the paper's path) on the same folds:"
cat "$out_dir/crossval_codebook.txt"
echo
echo "headline metrics, real Kinect scans (data/real, 11 scans labelled by hand; the default"
echo "model, its operating point chosen on generated validation rooms, never on these):"
cat "$out_dir/real.txt"
echo
echo "main job took $((SECONDS - job_start)) s after the build"
