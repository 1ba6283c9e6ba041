#!/usr/bin/env python3
"""Digest of what the workbench produced, without what may differ between two
identical runs (wall-clock times, the git commit, absolute paths): every table
of each dataset database row by row, and every other file byte by byte.
Two digests of the same commands before and after a refactoring must be equal.

usage: python3 tools/identity_digest.py OUT_DIR > digest.txt
"""
import hashlib
import json
import os
import re
import sqlite3
import sys

VOLATILE_RUN_COLUMNS = {"started", "git_commit", "git_dirty", "model_path"}
TIMING = re.compile(r"(latency|_ms\b|_ms_|seconds|_s$)")


def scrub(value):
    """JSON with timing keys removed, recursively."""
    if isinstance(value, dict):
        return {k: scrub(v) for k, v in value.items() if not TIMING.search(k)}
    if isinstance(value, list):
        return [scrub(v) for v in value]
    return value


def scrubbed_json_lines(data):
    """A JSON or JSON-lines file without its timing keys, as bytes."""
    text = data.decode()
    try:
        records = [json.loads(text)]
    except json.JSONDecodeError:
        records = [json.loads(line) for line in text.splitlines() if line.strip()]
    return "\n".join(json.dumps(scrub(r), sort_keys=True) for r in records).encode()


def digest_db(path):
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    lines = []
    tables = [r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table' ORDER BY name")]
    for table in tables:
        columns = [r[1] for r in db.execute(f"PRAGMA table_info({table})")]
        rows = []
        for row in db.execute(f"SELECT * FROM {table}"):
            record = dict(zip(columns, row))
            if table == "runs":
                for c in VOLATILE_RUN_COLUMNS:
                    record.pop(c, None)
                for c in ("options_json", "results_json"):
                    record[c] = json.dumps(scrub(json.loads(record[c])), sort_keys=True)
            if table == "run_metrics" and TIMING.search(record["name"]):
                continue
            if table == "run_frames":
                record.pop("total_ms", None)
                record.pop("timings_json", None)
            if table == "meta" and record.get("key") in ("created",):
                continue
            rows.append(repr(sorted((k, v if not isinstance(v, bytes) else hashlib.sha256(v).hexdigest())
                                    for k, v in record.items())))
        rows.sort()
        h = hashlib.sha256("\n".join(rows).encode()).hexdigest()
        lines.append(f"  {table}: {len(rows)} rows {h[:16]}")
    return lines


def main():
    root = sys.argv[1]
    for dirpath, _, files in sorted(os.walk(root)):
        for name in sorted(files):
            path = os.path.join(dirpath, name)
            rel = os.path.relpath(path, root)
            if name.endswith(("-wal", "-shm", ".log", ".html")) or name == "latency.png":
                continue
            if name.endswith(".db"):
                print(rel)
                for line in digest_db(path):
                    print(line)
                continue
            data = open(path, "rb").read()
            if os.sep not in rel and name.endswith(".txt"):
                continue  # explain*.txt: timings (digested apart)
            if os.sep not in rel and name.endswith(".json"):
                data = scrubbed_json_lines(data)  # detect*.json: timings
            print(f"{rel} {hashlib.sha256(data).hexdigest()[:16]}")


if __name__ == "__main__":
    main()
