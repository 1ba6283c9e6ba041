"""The Python module against the workbench CLI on the same data.

Run by ctest (python/furnidet) with PYTHONPATH at the build tree's python/
folder and FURN_WORKBENCH naming the CLI binary.
"""
import json
import math
import os
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np

import furnidet

WORKBENCH = os.environ["FURN_WORKBENCH"]


def workbench(*args):
    done = subprocess.run([WORKBENCH, *args, "--quiet"], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"workbench {' '.join(args)}: {done.stderr}")
    return done.stdout


class FurnidetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="furnidet_py_")
        cls.db = os.path.join(cls.dir, "synth.db")
        cls.model = os.path.join(cls.dir, "model.fcm")
        workbench("generate", "--catalog", "procedural:4", "--rooms", "5", "--frames", "2",
                  "--seed", "6", "--out", cls.db)  # rooms of all three splits
        workbench("train", "--no-vote-net", "--catalog", "procedural:4", "--azimuths", "4", "--words", "20",
                  "--vocab", "kmeans", "--out", cls.model)
        cls.dataset = furnidet.Dataset(cls.db)
        cls.detector = furnidet.Detector(cls.model)

    def test_frames_come_as_arrays_with_their_ground_truth(self):
        ids = self.dataset.frame_ids()
        self.assertEqual(len(ids), 10)
        self.assertEqual(len(self.dataset), 10)
        by_split = sum(len(self.dataset.frame_ids(s)) for s in ("train", "val", "test"))
        self.assertEqual(by_split, 10)
        frames = list(self.dataset.frames())
        self.assertEqual([f.id for f in frames], sorted(ids))
        frame = frames[0]
        depth = frame.depth
        self.assertEqual(depth.dtype, np.float32)
        self.assertEqual(depth.shape, (frame.height, frame.width))
        self.assertFalse(depth.flags.owndata)  # a view of the decoded buffer, not a copy
        self.assertGreater(np.count_nonzero(depth), depth.size // 2)
        self.assertTrue(np.all((depth == 0) | ((depth > 0.4) & (depth < 5))))
        # The ideal and noisy depths differ by sensor noise of millimetres to centimetres.
        ideal = frame.depth_ideal
        both = (depth > 0) & (ideal > 0)
        self.assertLess(np.median(np.abs(depth[both] - ideal[both])), 0.02)
        K = frame.K
        self.assertEqual(K.shape, (3, 3))
        self.assertEqual(tuple(frame.intrinsics), (K[0, 0], K[1, 1], K[0, 2], K[1, 2]))
        pose = frame.world_from_camera
        R = pose[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-9)
        self.assertTrue(0.5 < pose[2, 3] < 1.7)  # Kinect height over the floor
        # Every object with visible pixels shows in the id image with that count.
        instance_ids = frame.ids
        self.assertEqual(instance_ids.dtype, np.uint16)
        targets = [o for o in frame.objects if o["class"] is not None]
        self.assertTrue(targets)
        for obj in frame.objects:
            self.assertEqual(int(np.count_nonzero(instance_ids == obj["instance_id"])),
                             obj["visible_pixels"], obj)
            self.assertIn(obj["class"], furnidet.CLASSES + [None])

    def test_back_projected_floor_lies_at_zero_in_the_world(self):
        frame = self.dataset.frame(self.dataset.frame_ids()[0])
        depth, K = frame.depth_ideal, frame.K
        furniture = [o["instance_id"] for o in frame.objects]
        v, u = np.nonzero((depth > 0) & ~np.isin(frame.ids, furniture))
        z = depth[v, u]
        cam = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z, np.ones_like(z)])
        world = frame.world_from_camera @ cam
        # Background pixels are floor or walls; the lowest ones are the floor at z = 0.
        self.assertLess(abs(np.percentile(world[2], 1)), 0.01)

    def test_detection_matches_the_cli_on_the_same_frame(self):
        for frame in self.dataset.frames("test"):
            result = self.detector.detect_frame(frame)
            self.assertEqual(result.status, "detected")
            out = os.path.join(self.dir, f"det{frame.id}.json")
            workbench("detect", "--model", self.model, "--db", self.db, "--frame", str(frame.id),
                      "--out", out)
            with open(out) as f:
                cli = json.load(f)["detections"]
            self.assertEqual(len(result.detections), len(cli))
            for ours, theirs in zip(result.detections, cli):
                self.assertEqual(ours.cls, theirs["class"])
                self.assertAlmostEqual(ours.x, theirs["floor_point"][0], places=3)
                self.assertAlmostEqual(ours.y, theirs["floor_point"][1], places=3)
                self.assertAlmostEqual(ours.yaw, theirs["yaw"], places=3)
                for a, b in zip(ours.box["centre"], theirs["centre"]):
                    self.assertAlmostEqual(a, b, places=3)
                for a, b in zip(ours.box["size"], theirs["size"]):
                    self.assertAlmostEqual(a, b, places=3)
                self.assertEqual(ours.model, theirs["model"])
                self.assertAlmostEqual(ours.score, theirs["score"], places=3)

    def test_points_and_depth_give_the_same_detections(self):
        frame = self.dataset.frame(self.dataset.frame_ids("test")[0])
        depth, K = frame.depth, frame.K
        v, u = np.mgrid[0:depth.shape[0], 0:depth.shape[1]]
        z = np.where(depth > 0, depth, np.nan)
        organised = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z], axis=-1)
        a = self.detector.detect_depth(depth, K, world_from_camera=frame.world_from_camera)
        b = self.detector.detect_points(organised.astype(np.float32),
                                        world_from_camera=frame.world_from_camera)
        ra, rb = furnidet.records(a.detections), furnidet.records(b.detections)
        self.assertEqual(list(ra.cls), list(rb.cls))
        np.testing.assert_allclose(ra.x, rb.x, atol=1e-3)
        # Millimetres as uint16 are read as millimetres.
        mm = np.round(depth * 1000).astype(np.uint16)
        c = self.detector.detect_depth(mm, (K[0, 0], K[1, 1], K[0, 2], K[1, 2]),
                                       world_from_camera=frame.world_from_camera)
        self.assertEqual(len(c.detections), len(a.detections))

    def test_fused_halves_of_a_scan_are_the_scan(self):
        self.assertIsNone(self.detector.vote_net_input)  # a codebook model
        frame = self.dataset.frame(self.dataset.frame_ids("test")[0])
        depth, K = frame.depth, frame.K
        v, u = np.mgrid[0:depth.shape[0], 0:depth.shape[1]]
        z = np.where(depth > 0, depth, np.nan)
        points = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z],
                          axis=-1).reshape(-1, 3).astype(np.float32)
        points = points[np.isfinite(points).all(axis=1)]
        pose = frame.world_from_camera
        whole = self.detector.detect_points(points, world_from_camera=pose)
        half = len(points) // 2
        fused = self.detector.detect_fused([(points[:half], pose), (points[half:], pose)])
        self.assertEqual(fused.status, whole.status)
        rf, rw = furnidet.records(fused.detections), furnidet.records(whole.detections)
        self.assertEqual(list(rf.cls), list(rw.cls))
        np.testing.assert_allclose(rf.x, rw.x, atol=1e-5)
        np.testing.assert_allclose(rf.score, rw.score, atol=1e-6)
        # Registration leaves poses that already agree as they are.
        again = self.detector.detect_fused([(points[:half], pose), (points[half:], pose)],
                                           register=True)
        self.assertEqual(len(again.detections), len(whole.detections))
        level = self.detector.detect_fused([(points[:half], pose), (points[half:], pose)],
                                           register=True, planar=True)
        self.assertEqual(len(level.detections), len(whole.detections))
        with self.assertRaisesRegex(ValueError, "planar=True applies to register=True"):
            self.detector.detect_fused([(points, pose), (points, pose)], planar=True)
        with self.assertRaisesRegex(ValueError, "has no pose"):
            self.detector.detect_fused([(points, None), (points, pose)])
        with self.assertRaisesRegex(ValueError, "at least one scan"):
            self.detector.detect_fused([])
        with self.assertRaisesRegex(ValueError, "pair"):
            self.detector.detect_fused([(points,)])

    def test_records_and_unknown_pose(self):
        frame = self.dataset.frame(self.dataset.frame_ids()[1])
        result = self.detector.detect_depth(frame.depth, frame.K)  # the floor is found
        self.assertTrue(result.floor_estimated)
        self.assertIn("total", result.timings_ms)
        rec = furnidet.records(result.detections)
        self.assertEqual(len(rec), len(result.detections))
        self.assertEqual(rec.dtype, furnidet.DETECTION_DTYPE)
        self.assertTrue(np.all((rec.in_view >= 0) & (rec.in_view <= 1)))
        for i, d in enumerate(result.detections):
            self.assertEqual(d.in_view, rec.in_view[i])
        empty = self.detector.detect_points(np.zeros((0, 3), np.float32),
                                            world_from_camera=np.eye(4))
        self.assertEqual(empty.status, "no_points_in_range")
        self.assertEqual(len(furnidet.records(empty.detections)), 0)

    def test_in_view_error_tool_splits_detections_by_their_share_in_view(self):
        tool = os.path.join(os.path.dirname(__file__), "..", "..", "tools", "in_view_error.py")
        done = subprocess.run([sys.executable, tool, self.db, self.model], capture_output=True,
                              text=True)
        self.assertEqual(done.returncode, 0, done.stderr)
        lines = done.stdout.splitlines()
        self.assertTrue(lines[0].startswith("class      group"), done.stdout)
        for line in lines[1:]:
            self.assertIn(line.split()[1], ("cut", "whole"))
        bad = subprocess.run([sys.executable, tool, self.db, self.model, "--cut", "2"],
                             capture_output=True, text=True)
        self.assertNotEqual(bad.returncode, 0)
        self.assertIn("--cut", bad.stderr)

    def test_centre_error_tool_adds_databases_and_splits_losses_by_cut(self):
        tool = os.path.join(os.path.dirname(__file__), "..", "..", "tools", "centre_error.py")
        out = workbench("evaluate", "--model", self.model, "--db", self.db, "--split", "all")
        run = out.split()[1].rstrip(":")
        self.assertTrue(out.startswith("run ") and run.isdigit(), out)

        def losses(*specs):
            done = subprocess.run([sys.executable, tool, *specs, "--losses", "--min-visibility", "0"],
                                  capture_output=True, text=True)
            self.assertEqual(done.returncode, 0, done.stderr)
            rows = {}
            for line in done.stdout.splitlines()[2:]:
                cls, cut, n, *kinds = line.replace("(", " ").replace(")", " ").split()
                self.assertIn(cut, ("cut", "whole"))
                counts = [int(k) for k in kinds if not k.endswith("%")]
                self.assertEqual(sum(counts), int(n), line)
                rows[(cls, cut)] = int(n)
            return rows

        one = losses(f"{self.db}:{run}")
        self.assertGreater(sum(one.values()), 0)
        self.assertEqual(losses(f"{self.db}:{run}", f"{self.db}:{run}"),
                         {key: 2 * n for key, n in one.items()})

        def objects(*flags):  # class -> objects, summed over the rows (per model with --by-model)
            done = subprocess.run([sys.executable, tool, f"{self.db}:{run}", "--min-visibility",
                                   "0", *flags], capture_output=True, text=True)
            self.assertEqual(done.returncode, 0, done.stderr)
            counts = {}
            for line in done.stdout.splitlines()[2:]:
                fields = line.split()
                counts[fields[0]] = counts.get(fields[0], 0) + int(fields[2 if flags else 1])
            return counts

        per_class = objects()
        self.assertGreater(sum(per_class.values()), 0)
        self.assertEqual(objects("--by-model"), per_class)
        for bad, rule in ((f"{self.dir}/none.db:{run}", "no such dataset database"),
                          (f"{self.db}:x", "must be run ids")):
            done = subprocess.run([sys.executable, tool, bad], capture_output=True, text=True)
            self.assertNotEqual(done.returncode, 0)
            self.assertIn(rule, done.stderr)

    def test_centre_error_bias_reports_a_known_shift(self):
        # A copy of the dataset whose run has one detection per labelled
        # object, 4 cm to the camera's right of it: every row of --bias must
        # say forward 0, right +4 cm.
        tool = os.path.join(os.path.dirname(__file__), "..", "..", "tools", "centre_error.py")
        out = workbench("evaluate", "--model", self.model, "--db", self.db, "--split", "all")
        run = int(out.split()[1].rstrip(":"))
        shifted = os.path.join(self.dir, "shifted.db")
        db = sqlite3.connect(shifted)
        with sqlite3.connect(self.db) as source:  # its write-ahead log too
            source.backup(db)
        db.execute("DELETE FROM run_detections WHERE run_id = ?", (run,))
        frames = [r[0] for r in db.execute(
            "SELECT DISTINCT frame_id FROM run_frames WHERE run_id = ?", (run,))]
        placed = 0
        for frame in frames:
            room, pose = db.execute("SELECT room_id, world_from_camera FROM frames WHERE id = ?",
                                    (frame,)).fetchone()
            m = [float(v) for v in pose.split()]
            norm = math.hypot(m[0], m[4])
            rx, ry = m[0] / norm, m[4] / norm
            for cls, x, y in db.execute(
                    "SELECT o.class, o.reference_x, o.reference_y FROM objects o JOIN frame_objects f "
                    "ON f.instance_id = o.instance_id AND f.frame_id = ? WHERE o.room_id = ? AND "
                    "o.class != ''", (frame, room)).fetchall():
                db.execute("INSERT INTO run_detections VALUES (?, ?, ?, ?, ?, 0, 0, '', 1, 1, 1, 1)",
                           (run, frame, cls, x + 0.04 * rx, y + 0.04 * ry))
                placed += 1
        db.commit()
        db.close()
        self.assertGreater(placed, 0)
        done = subprocess.run([sys.executable, tool, f"{shifted}:{run}", "--bias",
                               "--min-visibility", "0"], capture_output=True, text=True)
        self.assertEqual(done.returncode, 0, done.stderr)
        rows = done.stdout.splitlines()[2:]
        self.assertGreater(len(rows), 0, done.stdout)
        for line in rows:
            *_, objects, forward, right, distance = line.split()
            self.assertGreater(int(objects), 0, line)
            self.assertEqual((float(forward), float(right), float(distance)), (0.0, 4.0, 4.0), line)

    def test_detection_releases_the_gil(self):
        frame = self.dataset.frame(self.dataset.frame_ids()[0])
        depth, K, pose = frame.depth, frame.K, frame.world_from_camera
        ticks = 0
        running = threading.Event()

        def detect():
            running.set()
            for _ in range(3):
                self.detector.detect_depth(depth, K, world_from_camera=pose)
            running.clear()

        worker = threading.Thread(target=detect)
        worker.start()
        running.wait()
        start = time.perf_counter()
        while running.is_set():
            ticks += 1
            time.sleep(0.001)
        elapsed = time.perf_counter() - start
        worker.join()
        # Holding the GIL, the loop would stall for whole detections.
        self.assertGreater(ticks, elapsed / 0.001 * 0.3, (ticks, elapsed))

    def test_evaluate_stores_a_run_and_returns_its_metrics(self):
        summary = furnidet.evaluate(self.model, self.db, split="all", label="python")
        self.assertEqual(summary["frames"], 10)
        self.assertIn("mAP@10cm", summary["metrics"])
        self.assertTrue(0 <= summary["metrics"]["mAP@10cm"] <= 1)
        runs = furnidet.Dataset(self.db).runs()
        self.assertEqual(runs[-1]["id"], summary["run_id"])
        self.assertEqual(runs[-1]["label"], "python")
        stored = furnidet.Dataset(self.db).run_metrics(summary["run_id"])
        self.assertEqual(stored["mAP@10cm"], summary["metrics"]["mAP@10cm"])

    def test_the_readme_python_section_runs_as_written(self):
        # The Python section moved from the README to docs/python-and-ros.md.
        readme = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "python-and-ros.md")
        with open(readme) as f:
            text = f.read()
        start = text.index("```python\n", text.index("### The Python module")) + len("```python\n")
        code = text[start:text.index("```", start)]
        code = code.replace("out/synth.db", self.db).replace("out/model.fcm", self.model)
        exec(compile(code, "docs/python-and-ros.md", "exec"), {})

    def test_bad_input_is_one_clear_error(self):
        frame = self.dataset.frame(self.dataset.frame_ids()[0])
        with self.assertRaisesRegex(ValueError, "3x3 K matrix"):
            self.detector.detect_depth(frame.depth, np.eye(2))
        with self.assertRaisesRegex(ValueError, r"\(N, 3\)"):
            self.detector.detect_points(np.zeros((5, 2), np.float32))
        scaled = np.diag([2.0, 2.0, 2.0, 1.0])
        with self.assertRaisesRegex(ValueError, "rotation"):
            self.detector.detect_depth(frame.depth, frame.K, world_from_camera=scaled)
        with self.assertRaisesRegex(ValueError, "last row 0 0 0 1"):
            self.detector.detect_depth(frame.depth, frame.K, world_from_camera=2 * np.eye(4))
        with self.assertRaisesRegex(ValueError, "depth_scale"):
            self.detector.detect_depth(frame.depth, frame.K, depth_scale=-1)
        with self.assertRaisesRegex(ValueError, "split 'nope'"):
            self.dataset.frame_ids("nope")
        with self.assertRaisesRegex(ValueError, "no frame 999999"):
            self.dataset.frame(999999)
        with self.assertRaises((OSError, ValueError)) as caught:
            furnidet.Dataset(os.path.join(self.dir, "missing.db"))
        self.assertIn("missing.db", str(caught.exception))
        with self.assertRaisesRegex(ValueError, "min_covered_fraction|unknown"):
            furnidet.Detector(self.model, options={"no_such_option": 1})

    def test_depth_units_are_read_as_given_or_refused(self):
        # Millimetres as float64 are refused in one line, not "nothing in
        # range"; NumPy's default int64 millimetres read as uint16 ones do.
        frame = self.dataset.frame(self.dataset.frame_ids()[0])
        millimetres = np.round(frame.depth * 1000)
        with self.assertRaisesRegex(ValueError, "float depth is in metres"):
            self.detector.detect_depth(millimetres, frame.K)
        as_uint16 = self.detector.detect_depth(millimetres.astype(np.uint16), frame.K)
        as_int64 = self.detector.detect_depth(millimetres.astype(np.int64), frame.K)
        self.assertEqual(as_int64.status, as_uint16.status)
        self.assertEqual(furnidet.records(as_int64.detections).tolist(),
                         furnidet.records(as_uint16.detections).tolist())
        self.assertGreater(as_uint16.points_in_range, 1000)

    def test_version_and_conventions_are_exported(self):
        self.assertEqual(furnidet.CONVENTIONS, 2)
        self.assertRegex(furnidet.__version__, r"^\d+\.\d+\.\d+$")
        self.assertIn("CONVENTIONS", furnidet.__all__)

    def test_hostile_arrays_and_arguments_are_one_input_error(self):
        # Issue 29: bool, object, complex and negative integer depth, a K with
        # skew, records of non-detections: each one InputError naming the rule.
        frame = self.dataset.frame(self.dataset.frame_ids()[0])
        shape = frame.depth.shape
        for depth, rule in ((np.zeros(shape, bool), "dtype bool"),
                            (np.zeros(shape, object), "dtype object"),
                            (np.zeros(shape, complex), "dtype complex"),
                            (np.full(shape, -5, np.int16), "negative integer")):
            with self.assertRaisesRegex(furnidet.InputError, rule):
                self.detector.detect_depth(depth, frame.K)
        skewed = np.array(frame.K)
        skewed[0, 1] = 3
        with self.assertRaisesRegex(furnidet.InputError, "no skew"):
            self.detector.detect_depth(frame.depth, skewed)
        with self.assertRaisesRegex(furnidet.InputError, "furnidet.Detection objects"):
            furnidet.records([1, 2, 3])


if __name__ == "__main__":
    unittest.main()
