"""furnidet: furniture detection from web CAD models, from Python.

    import furnidet
    dataset = furnidet.Dataset("synth.db")
    detector = furnidet.Detector("model.fcm")
    for frame in dataset.frames("test"):
        result = detector.detect_frame(frame)
        print(frame.id, furnidet.records(result.detections))
    metrics = furnidet.evaluate("model.fcm", "synth.db", split="test")["metrics"]

Frames carry their images as NumPy arrays (depth in metres, 0 = no return;
instance ids), their intrinsics (K), world_from_camera (4x4) and ground-truth
objects. Detection takes a depth image with its K, or an (N, 3) / (H, W, 3)
array of camera-frame points; world_from_camera is optional (without it the
floor is found). Detection and evaluation release the GIL.
"""

import numpy as _np

from ._furnidet import (CLASSES, CONVENTIONS, DatabaseError, Detection,
                        DetectionResult, Frame, InputError, __version__)
from ._furnidet import Dataset as _Dataset
from ._furnidet import Detector as _Detector
from ._furnidet import evaluate

__all__ = ["CLASSES", "CONVENTIONS", "Dataset", "DatabaseError", "Detection", "DetectionResult",
           "Detector", "Frame", "InputError", "evaluate", "records",
           "DETECTION_DTYPE"]


class Dataset(_Dataset):
    """A dataset database (read-only): rooms, frames and their ground truth."""

    def frames(self, split=None):
        """Frames of a split ('train', 'val', 'test'; None or 'all': every
        frame) in id order, reading one room at a time."""
        wanted = set(self.frame_ids(split))
        for room_id in self.room_ids():
            for frame in self.room(room_id):
                if frame.id in wanted:
                    yield frame

    def __iter__(self):
        return self.frames()

    def __len__(self):
        return len(self.frame_ids())


class Detector(_Detector):
    """A trained model (.fcm) loaded once; options as a dict, JSON text or None."""

    def detect_frame(self, frame):
        """Detect in a dataset frame as `workbench evaluate` does: its noisy
        depth, its intrinsics and, when known, its pose."""
        pose = frame.world_from_camera if frame.pose_known else None
        return self.detect_depth(frame.depth, frame.K, world_from_camera=pose)


# x, y, z: the floor point; yaw and the box (centre, size along the box's
# own x = the object's front, y, z) REP 103 (docs/conventions.md);
# verification and covered_fraction NaN and model "" without a fit; in_view
# the box's share inside the sensor's view (below 1: cut by the frame).
DETECTION_DTYPE = _np.dtype([
    ("cls", "U9"), ("x", "f8"), ("y", "f8"), ("z", "f8"), ("yaw", "f8"),
    ("cx", "f8"), ("cy", "f8"), ("cz", "f8"), ("sx", "f8"), ("sy", "f8"), ("sz", "f8"),
    ("score", "f8"), ("vote_weight", "f8"), ("verification", "f8"),
    ("covered_fraction", "f8"), ("model", "U64"), ("in_view", "f8")])


def _or_nan(value):
    return _np.nan if value is None else value


def records(detections):
    """Detections as a NumPy record array (one row each, best score first)."""
    if isinstance(detections, DetectionResult):
        detections = detections.detections
    bad = [d for d in detections if not isinstance(d, Detection)]
    if bad:
        raise InputError("records: detections must be furnidet.Detection objects (e.g. "
                         "result.detections), not %s" % type(bad[0]).__name__)
    rows = [(d.cls, d.x, d.y, d.z, d.yaw, *d.box["centre"], *d.box["size"], d.score,
             d.vote_weight, _or_nan(d.verification), _or_nan(d.covered_fraction), d.model or "",
             d.in_view)
            for d in detections]
    return _np.rec.array(_np.array(rows, dtype=DETECTION_DTYPE))
