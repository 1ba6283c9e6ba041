#!/usr/bin/env python3
"""How far detections cut by the frame land from the truth (issue 37).

Runs the detector (Python module, default options unless --all-candidates)
on a dataset's frames and, per class, splits its detections by their box's
share in view (Detection.in_view below --cut: "cut", else "whole"). For each
detection, the distance to the nearest labelled object of its class in the
frame; those within --match m count as true. Prints per class and group the
detections, the true ones, their median distance and the share within 10 cm.

  PYTHONPATH=build/python python3 tools/in_view_error.py seen.db model.fcm --split test
"""
import argparse
import math
import statistics
import sys

import furnidet


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("db")
    parser.add_argument("model")
    parser.add_argument("--split", default=None, help="train, val or test (default: every frame)")
    parser.add_argument("--cut", type=float, default=0.95, help="in_view below this is 'cut'")
    parser.add_argument("--match", type=float, default=0.3, help="true within this distance (m)")
    args = parser.parse_args()
    if not 0 < args.cut <= 1:
        sys.exit(f"--cut {args.cut}: must be in (0, 1]")
    dataset = furnidet.Dataset(args.db)
    detector = furnidet.Detector(args.model)
    errors = {}
    ids = dataset.frame_ids(args.split)
    for n, frame_id in enumerate(ids):
        frame = dataset.frame(frame_id)
        result = detector.detect_depth(frame.depth, frame.K,
                                       world_from_camera=frame.world_from_camera)
        for d in result.detections:
            nearest = min((math.hypot(o["x"] - d.x, o["y"] - d.y) for o in frame.objects
                           if o["class"] == d.cls), default=math.inf)
            group = "cut" if d.in_view < args.cut else "whole"
            errors.setdefault((d.cls, group), []).append(nearest)
        if n % 20 == 0 or n + 1 == len(ids):
            print(f"frame {n + 1}/{len(ids)}", file=sys.stderr, flush=True)
    print("class      group  detections  true  median_m  within_10cm")
    for (cls, group), values in sorted(errors.items()):
        true = [e for e in values if e <= args.match]
        median = statistics.median(true) if true else math.nan
        within = sum(e <= 0.1 for e in true) / len(true) if true else math.nan
        print(f"{cls:<10} {group:<6} {len(values):>10}  {len(true):>4}  {median:8.3f}  {within:11.2f}")


if __name__ == "__main__":
    main()
