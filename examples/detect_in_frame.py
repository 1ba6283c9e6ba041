"""Load a dataset, detect furniture in one frame, and plot it.

    PYTHONPATH=build/python python3 examples/detect_in_frame.py out/synth.db out/model.fcm \
        --out frame.png

Left: the simulated Kinect depth with the ground-truth objects' reference
points and the detections projected into the image. Right: the scene from
above (world frame, floor z = 0) with ground-truth footprints and detections.
"""
import argparse
import math

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

import furnidet

matplotlib.use("Agg")
COLOURS = {"chair": "tab:blue", "armchair": "tab:orange", "table": "tab:green",
           "sideboard": "tab:red", "sofa": "tab:purple"}


def project(frame, points_world):
    """Pixels (u, v) of world points seen by the frame's camera; None behind it."""
    camera_from_world = np.linalg.inv(frame.world_from_camera)
    out = []
    for p in points_world:
        c = camera_from_world @ np.append(p, 1.0)
        if c[2] <= 0.1:
            out.append(None)
            continue
        K = frame.K
        out.append((K[0, 0] * c[0] / c[2] + K[0, 2], K[1, 1] * c[1] / c[2] + K[1, 2]))
    return out


def footprint(box):
    """The outline of a REP 103 box from above: its size along its own x (the
    object's front) and y, turned by its yaw about its centre."""
    (x, y, _), (sx, sy, _), yaw = box["centre"], box["size"], box["yaw"]
    corners = np.array([[-sx, -sy], [sx, -sy], [sx, sy], [-sx, sy], [-sx, -sy]]) / 2
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    return corners @ rot.T + [x, y]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("db")
    parser.add_argument("model")
    parser.add_argument("--frame", type=int, help="frame id (default: the first test frame)")
    parser.add_argument("--out", default="frame.png")
    args = parser.parse_args()

    dataset = furnidet.Dataset(args.db)
    frame_id = args.frame if args.frame is not None else dataset.frame_ids("test")[0]
    frame = dataset.frame(frame_id)
    detector = furnidet.Detector(args.model)
    result = detector.detect_frame(frame)
    detections = furnidet.records(result.detections)
    print(f"frame {frame.id}: {len(detections)} detections in {result.timings_ms['total']:.0f} ms")
    for d in detections:
        print(f"  {d.cls:9s} x {d.x:6.2f}  y {d.y:6.2f}  yaw {math.degrees(d.yaw):6.1f}  "
              f"score {d.score:.2f}")

    targets = [o for o in frame.objects if o["class"] and o["visibility"] > 0]
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5))
    depth = np.where(frame.depth > 0, frame.depth, np.nan)
    image = left.imshow(depth, cmap="viridis")
    fig.colorbar(image, ax=left, label="depth (m)")
    # Markers above the image (zorder), truth as black-ringed white circles
    # so that they show on bright and dark depth alike.
    for obj, uv in zip(targets, project(frame, [(o["x"], o["y"], 0.0) for o in targets])):
        if uv:
            left.plot(*uv, "o", mfc="none", mec="black", ms=14, mew=3, zorder=3)
            left.plot(*uv, "o", mfc="none", mec="white", ms=14, mew=1.5, zorder=4)
    for d, uv in zip(detections, project(frame, [(d.x, d.y, 0.0) for d in detections])):
        if uv:
            left.plot(*uv, "x", color="black", ms=13, mew=5, zorder=5)
            left.plot(*uv, "x", color=COLOURS.get(d.cls, "k"), ms=12, mew=3, zorder=6)
            left.annotate(d.cls, uv, color="white", xytext=(6, -6), textcoords="offset points",
                          zorder=7, bbox=dict(boxstyle="round,pad=0.15", fc="black", alpha=0.6))
    left.set_title(f"frame {frame.id}: depth, truth (o) and detections (x) at floor level")
    left.axis("off")

    # The scan from above: every 7th pixel back-projected into the world frame.
    v, u = np.nonzero(frame.depth > 0)
    v, u = v[::7], u[::7]
    z = frame.depth[v, u]
    K = frame.K
    camera = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z, np.ones_like(z)])
    world = frame.world_from_camera @ camera
    above = world[2] > 0.05  # the floor left out
    right.scatter(world[0, above], world[1, above], s=0.5, color="0.45", linewidths=0)
    for obj in targets:
        xy = footprint(obj["box"])
        right.plot(xy[:, 0], xy[:, 1], color=COLOURS[obj["class"]], lw=1, ls="--")
    for det in result.detections:  # REP 103: the arrow along the box's x, the front
        colour = COLOURS.get(det.cls, "k")
        xy = footprint(det.box)
        right.plot(xy[:, 0], xy[:, 1], color=colour, lw=2)
        right.plot(det.x, det.y, "x", color=colour, ms=10, mew=3)
        right.arrow(det.x, det.y, 0.25 * math.cos(det.yaw), 0.25 * math.sin(det.yaw),
                    color=colour, head_width=0.05)
    sensor = frame.world_from_camera[:3, 3]
    right.set_title("from above: points (grey), truth (dashed), detections (box, x, front arrow)")
    right.plot(sensor[0], sensor[1], "k^", ms=10, label="sensor")
    right.set_aspect("equal")
    right.grid(True, alpha=0.3)
    right.set_xlabel("x (m)")
    right.set_ylabel("y (m)")
    handles = [plt.Line2D([], [], color=c, label=n) for n, c in COLOURS.items()]
    right.legend(handles=handles, loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=90)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
