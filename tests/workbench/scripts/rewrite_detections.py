"""Rewrites a furnidet-detections file as another program would write it.

    python3 rewrite_detections.py IN.jsonl OUT_DIR

One file per frame in OUT_DIR, the keys of every object in another order,
numbers as Python prints them (detections keep their order: among equal
scores, order decides matching, as in every benchmark).
What the workbench must score exactly as the file it wrote.
"""
import json
import os
import sys


def main():
    source, out_dir = sys.argv[1], sys.argv[2]
    os.makedirs(out_dir, exist_ok=True)
    with open(source) as lines:
        for text in lines:
            line = json.loads(text)
            detections = [dict(reversed(list(d.items()))) for d in line["detections"]]
            rewritten = {"detections": detections, "frame": line["frame"],
                         "version": 1, "format": "furnidet-detections",
                         "detector": "rewritten by a script"}
            if "time_ms" in line:
                rewritten["time_ms"] = line["time_ms"]
            with open(os.path.join(out_dir, f"frame-{line['frame']:06d}.jsonl"), "w") as out:
                out.write(json.dumps(rewritten, indent=None) + "\n")


if __name__ == "__main__":
    main()
