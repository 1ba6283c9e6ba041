#!/usr/bin/env python3
"""Centre error of a run's detections per class, by visibility (issue 37).

For every labelled object of a class seen at least --min-visibility within
--max-range of the camera, the distance to the nearest detection of its
class in the same frame (within --search m; farther: "none"). Prints per
class the objects, the median distance and the share within 5, 10 and 20 cm.
The run is the latest of --kind unless --runs are given; with --kind
crossval-fold every fold run of the latest crossval is taken.

  python3 tools/centre_error.py out/pe/pe-1.db --kind crossval-fold --min-visibility 0.5
"""
import argparse
import math
import sqlite3
import statistics
import sys


def camera_position(text):
    m = [float(v) for v in text.split()]
    return m[3], m[7]  # row-major 4x4: translation x, y


def fold_runs(db, kind, runs, folds):
    if runs:
        return [int(r) for r in runs.split(",")]
    ids = [r[0] for r in db.execute("SELECT id FROM runs WHERE kind = ? ORDER BY id DESC", (kind,))]
    if not ids:
        sys.exit(f"no run of kind '{kind}'")
    return sorted(ids[:folds]) if kind == "crossval-fold" else ids[:1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("db")
    parser.add_argument("--kind", default="crossval-fold")
    parser.add_argument("--runs", default="", help="run ids, comma-separated (default: the latest)")
    parser.add_argument("--folds", type=int, default=3, help="fold runs of the latest crossval")
    parser.add_argument("--min-visibility", type=float, default=0.5)
    parser.add_argument("--max-range", type=float, default=3.0)
    parser.add_argument("--search", type=float, default=0.8)
    args = parser.parse_args()
    db = sqlite3.connect(f"file:{args.db}?mode=ro", uri=True)
    runs = fold_runs(db, args.kind, args.runs, args.folds)
    distances = {}
    for run in runs:
        frames = [r[0] for r in db.execute(
            "SELECT DISTINCT frame_id FROM run_frames WHERE run_id = ?", (run,))]
        for frame in frames:
            room, pose = db.execute(
                "SELECT room_id, world_from_camera FROM frames WHERE id = ?", (frame,)).fetchone()
            cx, cy = camera_position(pose)
            detections = db.execute(
                "SELECT class, x, y FROM run_detections WHERE run_id = ? AND frame_id = ?",
                (run, frame)).fetchall()
            objects = db.execute(
                "SELECT o.class, o.reference_x, o.reference_y FROM objects o JOIN frame_objects f "
                "ON f.instance_id = o.instance_id AND f.frame_id = ? WHERE o.room_id = ? AND "
                "o.class != '' AND f.visibility >= ?", (frame, room, args.min_visibility)).fetchall()
            for cls, x, y in objects:
                if math.hypot(x - cx, y - cy) > args.max_range:
                    continue
                near = [math.hypot(x - dx, y - dy) for c, dx, dy in detections if c == cls]
                best = min(near) if near else math.inf
                distances.setdefault(cls, []).append(best if best <= args.search else math.inf)
    print(f"runs {runs}, objects seen >= {args.min_visibility:.0%} within {args.max_range} m")
    print(f"{'class':10} {'objects':>7} {'median cm':>9} {'<5cm':>6} {'<10cm':>6} {'<20cm':>6} {'none':>5}")
    for cls in sorted(distances):
        d = distances[cls]
        found = [v for v in d if math.isfinite(v)]
        median = statistics.median(d) * 100 if found and len(found) * 2 > len(d) else math.inf
        share = lambda r: sum(v < r for v in d) / len(d)
        print(f"{cls:10} {len(d):7d} {median:9.1f} {share(0.05):6.2f} {share(0.10):6.2f} "
              f"{share(0.20):6.2f} {len(d) - len(found):5d}")


if __name__ == "__main__":
    main()
