"""A detector that is not the workbench's: boxes from depth alone, scored by it.

It stands for any program of your own (a network, a baseline from the
literature): it reads a dataset as `workbench dataset export --format png`
writes it, finds furniture by height and footprint, and writes its
detections in the furnidet-detections format, which `workbench evaluate
--detections` scores exactly as the project's own runs (docs/evaluation.md,
"Scoring another detector"):

    workbench dataset export synth.db --format png --out export/
    python3 examples/external_detector.py export/ --split test --out heights.jsonl
    workbench evaluate --db synth.db --split test --detections heights.jsonl --label heights
    workbench report --db synth.db --out report-heights/

The method, deliberately simple: the depth back-projected into the world
(floor z = 0), points between 8 cm and 1.4 m high binned into 5 cm cells
seen from above, 8-connected groups of cells as objects, their footprint
from the principal axes of their points and their height from the highest
points, and a class by size (a table is low and wide, a chair small and
tall, ...). It uses NumPy and Pillow (Debian: python3-numpy, python3-pil).
"""
import argparse
import json
import math
import os
import sys
import time

import numpy as np
from PIL import Image

FORMAT = "furnidet-detections"
CELL_M = 0.05
MIN_Z_M, MAX_Z_M = 0.08, 1.4

# (class, height range, footprint area range, shorter side range, longer side range)
CLASSES = [
    ("table", (0.60, 0.85), (0.45, 4.0), (0.55, 1.6), (0.7, 2.6)),
    ("sideboard", (0.55, 1.10), (0.25, 1.6), (0.30, 0.65), (0.85, 2.4)),
    ("armchair", (0.60, 1.10), (0.40, 1.2), (0.60, 1.1), (0.60, 1.2)),
    ("chair", (0.70, 1.15), (0.12, 0.45), (0.35, 0.65), (0.35, 0.75)),
]


def world_points(frame, root):
    """The frame's depth as world points (N x 3)."""
    with Image.open(os.path.join(root, frame["depth"])) as image:
        depth = np.asarray(image, dtype=np.float64) * frame["depth_unit_m"]
    (fx, _, cx), (_, fy, cy), _ = frame["K"]
    v, u = np.nonzero(depth > 0)
    z = depth[v, u]
    camera = np.stack([(u - cx) * z / fx, (v - cy) * z / fy, z, np.ones_like(z)])
    world = (np.asarray(frame["world_from_camera"]) @ camera)[:3].T
    return world[(world[:, 2] > MIN_Z_M) & (world[:, 2] < MAX_Z_M)]


def groups_of_cells(points):
    """Lists of point indices, one per 8-connected group of occupied cells."""
    cells = np.floor(points[:, :2] / CELL_M).astype(np.int64)
    members = {}
    for index, cell in enumerate(map(tuple, cells)):
        members.setdefault(cell, []).append(index)
    occupied = {cell for cell, indices in members.items() if len(indices) >= 3}
    groups, seen = [], set()
    for start in sorted(occupied):
        if start in seen:
            continue
        seen.add(start)
        stack, group = [start], []
        while stack:
            cx, cy = stack.pop()
            group.extend(members[(cx, cy)])
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    near = (cx + dx, cy + dy)
                    if near in occupied and near not in seen:
                        seen.add(near)
                        stack.append(near)
        groups.append(group)
    return groups


def box_of(points):
    """Centre, size (along its yaw, across, up) and yaw of a group's points."""
    xy = points[:, :2]
    mean = xy.mean(axis=0)
    _, vectors = np.linalg.eigh(np.cov((xy - mean).T))
    major = vectors[:, 1]
    yaw = math.atan2(major[1], major[0])
    axes = np.array([[math.cos(yaw), math.sin(yaw)], [-math.sin(yaw), math.cos(yaw)]])
    local = (xy - mean) @ axes.T
    low, high = np.percentile(local, 2, axis=0), np.percentile(local, 98, axis=0)
    middle = mean + ((low + high) / 2) @ axes
    height = float(np.percentile(points[:, 2], 98))
    size = [float(high[0] - low[0]), float(high[1] - low[1]), height]
    return [float(middle[0]), float(middle[1]), height / 2], size, yaw


def classify(size):
    """The class whose ranges the box fits best, and how well (0..1), or None."""
    longer, shorter, height = max(size[:2]), min(size[:2]), size[2]
    area = longer * shorter
    best = None
    for name, heights, areas, shorters, longers in CLASSES:
        ranges = [(height, heights), (area, areas), (shorter, shorters), (longer, longers)]
        if not all(low <= value <= high for value, (low, high) in ranges):
            continue
        # 1 at the middle of every range, less towards its ends.
        fit = 1.0
        for value, (low, high) in ranges:
            fit *= 1 - 0.8 * abs(value - (low + high) / 2) / ((high - low) / 2)
        if best is None or fit > best[1]:
            best = (name, fit)
    return best


def detect(frame, root):
    points = world_points(frame, root)
    detections = []
    for group in groups_of_cells(points):
        if len(group) < 150:
            continue
        centre, size, yaw = box_of(points[group])
        found = classify(size)
        if found is None:
            continue
        name, fit = found
        detections.append({"class": name, "score": round(fit, 6), "centre": centre,
                           "size": size, "yaw": yaw})
    detections.sort(key=lambda d: -d["score"])
    return detections


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("export", help="a folder written by 'workbench dataset export --format png'")
    parser.add_argument("--out", required=True, help="the detections file to write (JSON lines)")
    parser.add_argument("--split", default="all", help="only frames of this split (default all)")
    args = parser.parse_args()
    with open(os.path.join(args.export, "frames.json")) as index_file:
        index = json.load(index_file)
    if index.get("format") != "furnidet-png-export":
        sys.exit(f"{args.export}/frames.json: not a png export of the workbench")
    frames = [f for f in index["frames"] if args.split in ("all", f["split"])]
    with open(args.out + ".partial", "w") as out:
        for number, frame in enumerate(frames, 1):
            start = time.perf_counter()
            detections = detect(frame, args.export)
            line = {"format": FORMAT, "version": 1, "frame": frame["frame"],
                    "detector": "examples/external_detector.py (heights and footprints)",
                    "time_ms": (time.perf_counter() - start) * 1000, "detections": detections}
            out.write(json.dumps(line) + "\n")
            print(f"frame {frame['frame']} ({number}/{len(frames)}): "
                  f"{len(detections)} detections", file=sys.stderr)
    os.replace(args.out + ".partial", args.out)


if __name__ == "__main__":
    main()
