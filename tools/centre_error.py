#!/usr/bin/env python3
"""Centre error of a run's detections per class, by visibility (issue 37).

For every labelled object of a class seen at least --min-visibility within
--max-range of the camera, the distance to the nearest detection of its
class in the same frame (within --search m; farther: "none"). Prints per
class the objects, the median distance and the share within 5, 10 and 20 cm.
The run is the latest of --kind unless --runs are given; with --kind
crossval-fold every fold run of the latest crossval is taken.

With --by-model, the same per CAD model (which held-out models a change
helps). With --losses, per class and by whether the object's image box touches the
image's side ("cut") or not ("whole"), where each object ends up: a
detection of its class within 10 cm, 10-20 cm, 20-50 cm, only another class
within 20 cm, or nothing. With --bias, per class and by the image side that
cuts the object, the median of the signed error of the nearest detection of
its class within 50 cm: along the camera's horizontal view (forward, + is
farther) and across it (right, + is the image's right). An object cut by
the image's left side with its detections to the right on the median is
placed towards the part in view. Several databases add up: give DB:RUN,RUN.

  python3 tools/centre_error.py out/pe/pe-1.db --kind crossval-fold --min-visibility 0.5
  python3 tools/centre_error.py pe-2.db:30 pe-3.db:15 --losses --min-visibility 0.15
  python3 tools/centre_error.py pe-3.db:2 --bias --min-visibility 0.15
"""
import argparse
import collections
import math
import os
import sqlite3
import statistics
import sys


# An object of the ground truth and where its class's nearest detection is:
# distance (inf: none within --search), the signed error (m) along the
# camera's horizontal forward and right (None: no detection within 0.5 m).
class Found(collections.namedtuple("Found", "cls side best other model forward right")):
    @property
    def cut(self):  # the image cuts the object on any side
        return self.side != "whole"

BIAS_SEARCH_M = 0.5


def camera_axes(text):
    """Position (x, y), horizontal forward and right unit vectors of a row-major 4x4 pose."""
    m = [float(v) for v in text.split()]
    def horizontal(x, y):  # a column of the rotation on the floor plane
        n = math.hypot(x, y) or 1.0
        return x / n, y / n
    # The optical frame: x right, z forward (docs/conventions.md).
    return (m[3], m[7]), horizontal(m[2], m[6]), horizontal(m[0], m[4])


def cut_side(u0, v0, u1, v1, width, height):
    left, right = u0 <= 0, u1 >= width - 1
    if left and right:
        return "both sides"
    if left or right:
        return "left" if left else "right"
    return "top/bottom" if v0 <= 0 or v1 >= height - 1 else "whole"


def fold_runs(db, kind, runs, folds):
    if runs:
        if not all(r.isdigit() for r in runs.split(",")):
            sys.exit(f"runs '{runs}': must be run ids, comma-separated")
        return [int(r) for r in runs.split(",")]
    ids = [r[0] for r in db.execute("SELECT id FROM runs WHERE kind = ? ORDER BY id DESC", (kind,))]
    if not ids:
        sys.exit(f"no run of kind '{kind}'")
    return sorted(ids[:folds]) if kind == "crossval-fold" else ids[:1]


def objects_of(db, runs, args):
    """A Found per labelled object of every frame of the runs."""
    for run in runs:
        frames = [r[0] for r in db.execute(
            "SELECT DISTINCT frame_id FROM run_frames WHERE run_id = ?", (run,))]
        for frame in frames:
            room, pose, width, height = db.execute(
                "SELECT room_id, world_from_camera, width, height FROM frames WHERE id = ?",
                (frame,)).fetchone()
            (cx, cy), forward, right = camera_axes(pose)
            detections = db.execute(
                "SELECT class, x, y FROM run_detections WHERE run_id = ? AND frame_id = ?",
                (run, frame)).fetchall()
            objects = db.execute(
                "SELECT o.class, o.reference_x, o.reference_y, f.amodal_u0, f.amodal_v0, "
                "f.amodal_u1, f.amodal_v1, o.model_id FROM objects o JOIN frame_objects f "
                "ON f.instance_id = o.instance_id AND f.frame_id = ? WHERE o.room_id = ? AND "
                "o.class != '' AND f.visibility >= ?", (frame, room, args.min_visibility)).fetchall()
            for cls, x, y, u0, v0, u1, v1, model in objects:
                if math.hypot(x - cx, y - cy) > args.max_range:
                    continue
                side = cut_side(u0, v0, u1, v1, width, height)
                near = sorted((math.hypot(x - dx, y - dy), c, dx, dy) for c, dx, dy in detections)
                own = next((n for n in near if n[1] == cls), None)
                best = own[0] if own else math.inf
                other = next((c for d, c, _, _ in near if c != cls and d < 0.2), "")
                along = across = None
                if own and best <= BIAS_SEARCH_M:
                    ex, ey = own[2] - x, own[3] - y
                    along, across = ex * forward[0] + ey * forward[1], ex * right[0] + ey * right[1]
                yield Found(cls, side, best if best <= args.search else math.inf, other, model,
                            along, across)


def print_distances(found_objects, header, by_model=False):
    distances = {}
    for found in found_objects:
        key = (found.cls, found.model) if by_model else found.cls
        distances.setdefault(key, []).append(found.best)
    print(header)
    width = max([len(f"{c} {m}") for c, m in distances] if by_model else [10])
    print(f"{'class model' if by_model else 'class':{width}} {'objects':>7} {'median cm':>9} "
          f"{'<5cm':>6} {'<10cm':>6} {'<20cm':>6} {'none':>5}")
    for key in sorted(distances):
        d = distances[key]
        found = [v for v in d if math.isfinite(v)]
        median = statistics.median(d) * 100 if found and len(found) * 2 > len(d) else math.inf
        share = lambda r: sum(v < r for v in d) / len(d)
        name = " ".join(key) if by_model else key
        print(f"{name:{width}} {len(d):7d} {median:9.1f} {share(0.05):6.2f} {share(0.10):6.2f} "
              f"{share(0.20):6.2f} {len(d) - len(found):5d}")


def print_losses(found_objects, header):
    kinds = ["<10cm", "10-20cm", "20-50cm", "other class", "nothing"]
    counts = {}
    for found in found_objects:
        best = found.best
        kind = (kinds[0] if best < 0.1 else kinds[1] if best < 0.2 else
                kinds[3] if found.other else kinds[2] if best < 0.5 else kinds[4])
        row = counts.setdefault((found.cls, "cut" if found.cut else "whole"),
                                dict.fromkeys(kinds, 0))
        row[kind] += 1
    print(header + "; where each object ends up (other class: only another class within 20 cm)")
    print(f"{'class':10} {'':5} {'objects':>7} " + " ".join(f"{k:>12}" for k in kinds))
    for (cls, cut), row in sorted(counts.items()):
        n = sum(row.values())
        print(f"{cls:10} {cut:5} {n:7d} " +
              " ".join(f"{row[k]:5d} ({row[k] / n:4.0%})" for k in kinds))


def print_bias(found_objects, header):
    errors = {}
    for found in found_objects:
        if found.forward is not None:
            errors.setdefault((found.cls, found.side), []).append((found.forward, found.right))
    print(header + f"; signed error of the nearest detection of the class within "
          f"{BIAS_SEARCH_M * 100:.0f} cm (cm; forward: + farther, right: + the image's right)")
    print(f"{'class':10} {'cut by':10} {'objects':>7} {'forward':>8} {'right':>8} {'distance':>8}")
    for (cls, side), pairs in sorted(errors.items()):
        median = lambda values: statistics.median(values) * 100
        print(f"{cls:10} {side:10} {len(pairs):7d} {median([f for f, _ in pairs]):8.1f} "
              f"{median([r for _, r in pairs]):8.1f} "
              f"{median([math.hypot(f, r) for f, r in pairs]):8.1f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("db", nargs="+", help="a dataset database, or DB:RUN,RUN")
    parser.add_argument("--kind", default="crossval-fold")
    parser.add_argument("--runs", default="", help="run ids, comma-separated (default: the latest)")
    parser.add_argument("--folds", type=int, default=3, help="fold runs of the latest crossval")
    parser.add_argument("--min-visibility", type=float, default=0.5)
    parser.add_argument("--max-range", type=float, default=3.0)
    parser.add_argument("--search", type=float, default=0.8)
    parser.add_argument("--losses", action="store_true", help="where each object ends up, cut or whole")
    parser.add_argument("--by-model", action="store_true",
                        help="distances per CAD model instead of per class")
    parser.add_argument("--bias", action="store_true",
                        help="median signed error by the image side that cuts the object")
    args = parser.parse_args()
    found_objects, names = [], []
    for spec in args.db:
        path, _, run_list = spec.partition(":")
        if not os.path.isfile(path):
            sys.exit(f"{path}: no such dataset database")
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        runs = fold_runs(db, args.kind, run_list or args.runs, args.folds)
        found_objects += list(objects_of(db, runs, args))
        names.append(f"{path} runs {runs}")
    header = f"{'; '.join(names)}: objects seen >= {args.min_visibility:.0%} within {args.max_range} m"
    if args.losses:
        print_losses(found_objects, header)
    elif args.bias:
        print_bias(found_objects, header)
    else:
        print_distances(found_objects, header, args.by_model)


if __name__ == "__main__":
    main()
