// The Python module `furnidet` (its compiled half, `furnidet._furnidet`):
// dataset frames as NumPy arrays, detection in NumPy depth images and point
// arrays, and `evaluate`, for notebooks. The pure-Python half
// (workbench/python/furnidet/__init__.py) adds iteration and record arrays.
//
//   import furnidet
//   dataset = furnidet.Dataset("synth.db")
//   frame = dataset.frame(dataset.frame_ids("test")[0])
//   detector = furnidet.Detector("model.fcm")
//   result = detector.detect_depth(frame.depth, frame.K)
//
// Images decoded from the database are handed to NumPy without a copy (the
// array owns the decoded buffer); detection and evaluation release the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/detector/detection_box.h"
#include "core/detector/detector.h"
#include "core/geometry/scan_fusion.h"
#include "core/model/furniture_class.h"
#include "core/model/trained_model.h"
#include "core/util/error.h"
#include "db/dataset_db.h"
#include "db/sqlite.h"
#include "renderers/camera.h"
#include "workbench/formats/camera_file.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/options_file.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/evaluate.h"
#include "workbench/pipelines/import_real.h"

namespace py = pybind11;

namespace furn {
namespace {

// A depth image's median return beyond this (m) is no sensor's: millimetres
// passed as float metres (Kinect v1 reaches ~10 m, long-range ToF ~50 m).
constexpr double kMaxMedianDepthM = 100;

// A NumPy array that owns `values` (moved, not copied) with the given shape.
template <typename T>
py::array_t<T> OwningArray(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<T>(std::move(values));
  py::capsule free_when_done(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, owned->data(), free_when_done);
}

py::array_t<double> MatrixArray(const Eigen::Matrix4d& matrix) {
  py::array_t<double> array({4, 4});
  auto view = array.mutable_unchecked<2>();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) view(r, c) = matrix(r, c);
  }
  return array;
}

Eigen::Isometry3d IsometryFromArray(const py::handle& object, const std::string& what) {
  const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(object);
  if (!array || array.ndim() != 2 || array.shape(0) != 4 || array.shape(1) != 4) {
    throw InputError(what + " must be a 4x4 matrix");
  }
  Eigen::Matrix4d matrix;
  auto view = array.unchecked<2>();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) matrix(r, c) = view(r, c);
  }
  if (!matrix.allFinite() || (matrix.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
    throw InputError(what + " must be finite with last row 0 0 0 1");
  }
  const Eigen::Matrix3d rotation = matrix.topLeftCorner<3, 3>();
  if ((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() > 1e-4 ||
      rotation.determinant() < 0) {
    throw InputError(what + " must hold a rotation (orthonormal, determinant +1) in its 3x3 part");
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.matrix() = matrix;
  return pose;
}

// Intrinsics from a 3x3 K matrix or (fx, fy, cx, cy), for an image of the given size.
CameraIntrinsics IntrinsicsFromPython(const py::handle& k, int width, int height) {
  CameraIntrinsics camera;
  camera.width = width;
  camera.height = height;
  const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(k);
  if (array && array.ndim() == 2 && array.shape(0) == 3 && array.shape(1) == 3) {
    auto view = array.unchecked<2>();
    std::vector<double> values;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) values.push_back(view(r, c));
    }
    return CameraFromMatrix(values, width, height, "K");  // one check for every source
  } else if (array && array.ndim() == 1 && array.shape(0) == 4) {
    auto view = array.unchecked<1>();
    camera.fx = view(0);
    camera.fy = view(1);
    camera.cx = view(2);
    camera.cy = view(3);
  } else {
    throw InputError("intrinsics must be a 3x3 K matrix or (fx, fy, cx, cy)");
  }
  camera.Check();
  return camera;
}

py::array_t<double> KArray(const CameraIntrinsics& camera) {
  py::array_t<double> array({3, 3});
  auto view = array.mutable_unchecked<2>();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) view(r, c) = 0;
  }
  view(0, 0) = camera.fx;
  view(1, 1) = camera.fy;
  view(0, 2) = camera.cx;
  view(1, 2) = camera.cy;
  view(2, 2) = 1;
  return array;
}

// One frame of a dataset: images decoded on first access.
struct PyFrame {
  int64_t id = 0, room_id = 0;
  int frame_index = 0;
  std::string split;
  CameraIntrinsics camera;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  bool pose_known = true;  // false: an imported real scan whose floor the detector finds
  std::vector<uint8_t> depth_png, depth_ideal_png, ids_png;
  py::list objects;

  py::array_t<float> Depth(const std::vector<uint8_t>& png, const char* which) const {
    DepthFrame frame = DecodeDepthPng(png, "frame " + std::to_string(id) + " " + which);
    return OwningArray(std::move(frame.depth), {frame.height, frame.width});
  }
  py::array_t<uint16_t> Ids() const {
    if (ids_png.empty()) throw InputError("frame " + std::to_string(id) + " has no id image");
    DepthFrame frame;
    frame.Resize(camera.width, camera.height);
    DecodeIdPng(ids_png, "frame " + std::to_string(id) + " ids", &frame);
    return OwningArray(std::move(frame.instance_ids), {frame.height, frame.width});
  }
};

py::dict BoxDict(const OrientedBox& box) {
  py::dict d;
  d["centre"] = py::make_tuple(box.centre.x(), box.centre.y(), box.centre.z());
  d["size"] = py::make_tuple(box.size.x(), box.size.y(), box.size.z());
  d["yaw"] = box.yaw;
  const std::array<double, 4> q = QuaternionXyzw(box.yaw);
  d["quaternion"] = py::make_tuple(q[0], q[1], q[2], q[3]);
  return d;
}

py::dict ObjectDict(const ObjectRecord& object, const FrameObjectRecord* seen) {
  py::dict d;
  d["instance_id"] = object.instance_id;
  d["model"] = object.model_id;
  d["class"] = object.furniture_class ? py::object(py::str(ClassName(*object.furniture_class)))
                                      : py::object(py::none());
  d["x"] = object.reference_x;  // the reference point: footprint centre on the floor
  d["y"] = object.reference_y;
  d["z"] = object.z;
  // REP 103 (docs/conventions.md): the box's x is the object's front.
  const OrientedBox box = WorldBoxOf(object.Footprint(), object.z, object.height);
  d["yaw"] = box.yaw;
  d["size"] = py::make_tuple(box.size.x(), box.size.y(), box.size.z());
  d["box"] = BoxDict(box);
  d["visibility"] = seen ? seen->visibility : 0.0;
  d["visible_pixels"] = seen ? seen->visible_pixels : 0;
  d["amodal_pixels"] = seen ? seen->amodal_pixels : 0;
  d["in_frustum"] = seen ? seen->in_frustum : false;
  return d;
}

class PyDataset {
 public:
  explicit PyDataset(const std::string& path) : db_(path, DatasetDb::Mode::kReadOnly) {
    if (const std::optional<std::string> generation = db_.GenerationOptions()) {
      generation_json_ = *generation;
      estimated_pose_ = FramesWithEstimatedPose(*generation);
    }
    for (int64_t room_id : db_.RoomIds()) {
      const RoomRecord room = db_.ReadRoom(room_id, /*with_images=*/false);
      for (const FrameRecord& frame : room.frames)
        index_.push_back({frame.id, room_id, room.split});
    }
  }

  const std::string& path() const { return db_.path(); }
  const std::string& generation_json() const { return generation_json_; }

  // Frame ids of a split (train, val, test) or of all, in id order.
  std::vector<int64_t> FrameIds(const std::optional<std::string>& split) const {
    const Split selected = split ? ParseSplit(*split) : Split::kAll;
    std::vector<int64_t> ids;
    for (const Entry& entry : index_) {
      if (InSplit(entry.split, selected)) ids.push_back(entry.frame_id);
    }
    return ids;
  }

  // Every frame of one room, with its ground truth.
  std::vector<PyFrame> Room(int64_t room_id) {
    const RoomRecord room = db_.ReadRoom(room_id, /*with_images=*/true);
    std::vector<PyFrame> frames;
    for (const FrameRecord& record : room.frames) {
      PyFrame frame;
      frame.id = record.id;
      frame.room_id = room.id;
      frame.frame_index = record.frame_index;
      frame.split = EnumName(room.split);
      frame.camera = IntrinsicsOf(record);
      frame.world_from_camera = record.world_from_camera;
      frame.pose_known = estimated_pose_.count(record.id) == 0;
      frame.depth_png = record.depth_noisy_png;
      frame.depth_ideal_png = record.depth_ideal_png;
      frame.ids_png = record.ids_png;
      std::map<int, const FrameObjectRecord*> seen;
      for (const FrameObjectRecord& object : record.objects) seen[object.instance_id] = &object;
      for (const ObjectRecord& object : room.objects) {
        const auto it = seen.find(object.instance_id);
        frame.objects.append(ObjectDict(object, it == seen.end() ? nullptr : it->second));
      }
      frames.push_back(std::move(frame));
    }
    return frames;
  }

  PyFrame Frame(int64_t frame_id) {
    const std::optional<int64_t> room = db_.RoomOfFrame(frame_id);
    if (!room) throw InputError(db_.path() + ": no frame " + std::to_string(frame_id));
    for (PyFrame& frame : Room(*room)) {
      if (frame.id == frame_id) return std::move(frame);
    }
    throw InputError(db_.path() + ": no frame " + std::to_string(frame_id));
  }

  std::vector<int64_t> RoomIds() { return db_.RoomIds(); }

  py::list Models() {
    py::list models;
    for (const ModelRecord& model : db_.ReadModels()) {
      py::dict d;
      d["id"] = model.id;
      d["class"] = model.furniture_class ? py::object(py::str(ClassName(*model.furniture_class)))
                                         : py::object(py::none());
      d["size"] = py::make_tuple(model.size_m.x(), model.size_m.y(), model.size_m.z());
      d["evaluation_only"] = model.evaluation_only;
      models.append(d);
    }
    return models;
  }

  py::list Runs() {
    py::list runs;
    for (const RunRecord& run : db_.Runs()) {
      py::dict d;
      d["id"] = run.id;
      d["kind"] = run.kind;
      d["label"] = run.label;
      d["started"] = run.started;
      d["git_commit"] = run.git_commit;
      d["split"] = EnumName(run.split);
      d["model_path"] = run.model_path;
      runs.append(d);
    }
    return runs;
  }

  std::map<std::string, double> RunMetrics(int64_t run_id) { return db_.RunMetrics(run_id); }

 private:
  struct Entry {
    int64_t frame_id, room_id;
    Split split;
  };
  DatasetDb db_;
  std::string generation_json_;
  std::set<int64_t> estimated_pose_;
  std::vector<Entry> index_;
};

// Detector options from None, a dict or a JSON string (the "detector" part
// of an options file, or a whole options file).
DetectorOptions OptionsFromPython(const py::object& options) {
  if (options.is_none()) return DetectorOptions{};
  std::string text;
  if (py::isinstance<py::str>(options)) {
    text = options.cast<std::string>();
  } else if (py::isinstance<py::dict>(options)) {
    text = py::module_::import("json").attr("dumps")(options).cast<std::string>();
  } else {
    throw InputError("options must be None, a dict or a JSON string");
  }
  return DetectorOptionsFromJson(text, "options");
}

// A detection as Python sees it: the engine's, with its REP 103 box
// (docs/conventions.md), which needs the model that detected it.
struct PyDetection {
  Detection detection;
  OrientedBox box;
};
struct PyResult {
  DetectionResult result;
  std::vector<PyDetection> detections;
};

class PyDetector {
 public:
  PyDetector(const std::string& model_path, const py::object& options)
      : detector_(LoadTrainedModel(model_path), OptionsFromPython(options)) {}

  // Depth in metres (float) or in 1/depth_scale metres (integers; default
  // 1000: millimetres); 0 or non-finite: no return.
  PyResult DetectDepth(const py::array& depth,
                       const py::object& k,
                       const py::object& world_from_camera,
                       std::optional<double> depth_scale) const {
    if (depth.ndim() != 2) throw InputError("depth must be a 2-D array (height, width)");
    // Depth is float metres or integer units; booleans, objects and complex
    // numbers are refused, and so are negative integers.
    const char kind = depth.dtype().kind();
    if (kind != 'f' && kind != 'u' && kind != 'i') {
      throw InputError("depth must hold floats (metres) or integers (units), not dtype " +
                       std::string(py::str(depth.dtype())));
    }
    const int height = static_cast<int>(depth.shape(0)), width = static_cast<int>(depth.shape(1));
    const CameraIntrinsics camera = IntrinsicsFromPython(k, width, height);
    const bool integer = kind == 'u' || kind == 'i';  // any width: NumPy's int64 too
    const double scale = depth_scale.value_or(integer ? 1000.0 : 1.0);
    if (!(scale > 0) || !std::isfinite(scale) || scale > 1e6) {
      throw InputError("depth_scale " + std::to_string(scale) +
                       " must be a positive number of units per metre (at most 1e6)");
    }
    const auto metres =
        py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(depth);
    if (!metres) throw InputError("depth must hold numbers");
    DepthFrame frame;
    frame.Reshape(width, height);
    const double* values = metres.data();
    if (kind == 'i') {
      for (size_t i = 0; i < frame.depth.size(); ++i) {
        if (values[i] < 0)
          throw InputError("depth holds a negative integer (" + std::to_string(values[i]) + ")");
      }
    }
    std::vector<float> returns;
    for (size_t i = 0; i < frame.depth.size(); ++i) {
      const double z = values[i] / scale;
      frame.depth[i] = std::isfinite(z) && z > 0 ? static_cast<float>(z) : 0.0f;
      if (frame.depth[i] > 0) returns.push_back(frame.depth[i]);
    }
    // Millimetres given as floats read as metres put every point kilometres
    // away: say so rather than find nothing in range.
    if (!returns.empty()) {
      std::nth_element(returns.begin(), returns.begin() + returns.size() / 2, returns.end());
      const double median = returns[returns.size() / 2];
      if (median > kMaxMedianDepthM)
        throw InputError("depth's median return is " +
                         std::to_string(static_cast<int64_t>(median)) +
                         " m, beyond any depth sensor's range: float depth is in metres (pass "
                         "depth / 1000 for millimetres, or depth_scale=1000)");
    }
    DetectionInput input;
    input.points = BackProject(frame, camera);
    input.width = width;
    input.height = height;
    if (!world_from_camera.is_none()) {
      input.world_from_camera = IsometryFromArray(world_from_camera, "world_from_camera");
    }
    return Run(input);
  }

  // Camera-frame points, (N, 3) or organised (H, W, 3), metres; NaN: none.
  PyResult DetectPoints(const py::array& points, const py::object& world_from_camera) const {
    return Run(InputOfPoints(points, world_from_camera));
  }

  // Several (points, world_from_camera) scans as one (FuseScans), seen from
  // the last one's camera; their poses refined first when `register_poses`
  // (in x, y and yaw only when `planar`).
  PyResult DetectFused(const py::list& scans, bool register_poses, bool planar) const {
    std::vector<DetectionInput> inputs;
    for (const py::handle& scan : scans) {
      const py::tuple pair = py::reinterpret_borrow<py::object>(scan).cast<py::tuple>();
      if (pair.size() != 2)
        throw InputError("each scan must be a (points, world_from_camera) pair");
      inputs.push_back(InputOfPoints(pair[0].cast<py::array>(), pair[1]));
    }
    if (inputs.empty()) throw InputError("detect_fused needs at least one scan");
    const size_t reference = inputs.size() - 1;
    if (planar && !register_poses) throw InputError("planar=True applies to register=True");
    if (register_poses && inputs.size() > 1) {
      ScanRegistrationOptions registration;
      registration.planar = planar;
      inputs = WithRegisteredPoses(std::move(inputs), reference, registration);
    }
    return Run(FuseScans(inputs, reference));
  }

  std::vector<std::string> ModelNames() const { return detector_.model().model_names; }
  // What the vote network was trained on (TrainedModel::vote_net_input), None
  // for a codebook model or a model file older than format 10.
  py::object VoteNetInput() const {
    const TrainedModel& model = detector_.model();
    const furn::VoteNetInput& input = model.vote_net_input;
    if (model.vote_net.empty() || !input.recorded) return py::none();
    py::dict out;
    out["fused_share"] = input.fused_share;
    out["pose_noise_m"] = input.pose_noise_m;
    out["pose_noise_deg"] = input.pose_noise_deg;
    out["planar"] = input.planar;
    return std::move(out);
  }

 private:
  static DetectionInput InputOfPoints(const py::array& points,
                                      const py::object& world_from_camera) {
    const auto xyz = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(points);
    if (!xyz) throw InputError("points must hold numbers");
    DetectionInput input;
    size_t count = 0;
    if (xyz.ndim() == 2 && xyz.shape(1) == 3) {
      count = xyz.shape(0);
    } else if (xyz.ndim() == 3 && xyz.shape(2) == 3) {
      input.height = static_cast<int>(xyz.shape(0));
      input.width = static_cast<int>(xyz.shape(1));
      count = static_cast<size_t>(input.width) * input.height;
    } else {
      throw InputError("points must be an (N, 3) or (H, W, 3) array");
    }
    input.points.resize(count);
    const float* data = xyz.data();
    for (size_t i = 0; i < count; ++i) {
      input.points[i] = Eigen::Vector3f(data[3 * i], data[3 * i + 1], data[3 * i + 2]);
    }
    if (!world_from_camera.is_none()) {
      input.world_from_camera = IsometryFromArray(world_from_camera, "world_from_camera");
    }
    return input;
  }

  PyResult Run(const DetectionInput& input) const {
    py::gil_scoped_release release;
    PyResult out;
    out.result = detector_.Detect(input);
    for (const Detection& d : out.result.detections)
      out.detections.push_back({d, DetectionBoxInWorld(d, detector_.model())});
    return out;
  }
  Detector detector_;
};

py::dict EvaluateFromPython(const std::string& model,
                            const std::string& db,
                            const std::string& split,
                            int max_frames,
                            const std::string& label,
                            const py::object& options) {
  EvaluateCommandOptions command;
  command.split = ParseSplit(split);
  command.max_frames = max_frames;
  command.label = label;
  command.detector = OptionsFromPython(options);
  EvaluateSummary summary;
  {
    py::gil_scoped_release release;
    summary = EvaluateModel(model, db, command);
  }
  py::dict d;
  d["run_id"] = summary.run_id;
  d["frames"] = summary.frames;
  d["frames_without_points"] = summary.frames_without_points;
  d["frames_without_floor"] = summary.frames_without_floor;
  d["seconds"] = summary.seconds;
  d["metrics"] = summary.result.metrics;
  return d;
}

// Frame and Dataset: a dataset database's frames as NumPy arrays.
void BindDataset(py::module_& m) {
  py::class_<PyFrame>(m, "Frame", "A dataset frame: images decoded on access, ground truth.")
      .def_readonly("id", &PyFrame::id)
      .def_readonly("room_id", &PyFrame::room_id)
      .def_readonly("frame_index", &PyFrame::frame_index)
      .def_readonly("split", &PyFrame::split)
      .def_readonly(
          "pose_known", &PyFrame::pose_known, "False for a real scan whose floor is found")
      .def_property_readonly("width", [](const PyFrame& f) { return f.camera.width; })
      .def_property_readonly("height", [](const PyFrame& f) { return f.camera.height; })
      .def_property_readonly("K", [](const PyFrame& f) { return KArray(f.camera); })
      .def_property_readonly("intrinsics",
                             [](const PyFrame& f) {
                               return py::make_tuple(
                                   f.camera.fx, f.camera.fy, f.camera.cx, f.camera.cy);
                             })
      .def_property_readonly(
          "world_from_camera",
          [](const PyFrame& f) { return MatrixArray(f.world_from_camera.matrix()); },
          "4x4; camera frame optical (x right, y down, z forward), world z up, floor z = 0")
      .def_property_readonly(
          "depth",
          [](const PyFrame& f) { return f.Depth(f.depth_png, "noisy depth"); },
          "float32 (H, W) metres of the simulated sensor; 0 = no return")
      .def_property_readonly(
          "depth_ideal",
          [](const PyFrame& f) { return f.Depth(f.depth_ideal_png, "ideal depth"); },
          "float32 (H, W) metres, noise-free")
      .def_property_readonly("ids", &PyFrame::Ids, "uint16 (H, W) instance ids; 0 = none")
      .def_readonly("objects", &PyFrame::objects, "ground truth: one dict per object")
      .def("__repr__", [](const PyFrame& f) {
        return "<furnidet.Frame " + std::to_string(f.id) + " of room " + std::to_string(f.room_id) +
               " (" + f.split + ")>";
      });

  py::class_<PyDataset>(m, "Dataset", "A dataset database, read-only.")
      .def(py::init<const std::string&>(), py::arg("path"))
      .def_property_readonly("path", &PyDataset::path)
      .def_property_readonly("generation_json", &PyDataset::generation_json)
      .def("frame_ids", &PyDataset::FrameIds, py::arg("split") = py::none())
      .def("room_ids", &PyDataset::RoomIds)
      .def("room", &PyDataset::Room, py::arg("room_id"))
      .def("frame", &PyDataset::Frame, py::arg("frame_id"))
      .def("models", &PyDataset::Models)
      .def("runs", &PyDataset::Runs)
      .def("run_metrics", &PyDataset::RunMetrics, py::arg("run_id"));
}

// Detection and DetectionResult, as Python sees them (REP 103 boxes).
void BindDetections(py::module_& m) {
  // Conventions version 2 (docs/conventions.md): yaw and box REP 103, x the object's front.
  m.attr("CONVENTIONS") = 2;
  m.attr("__version__") = FURN_VERSION;
  py::class_<PyDetection>(
      m,
      "Detection",
      "One detected piece, world frame (floor at z = 0, z up): x, y the floor point under it; "
      "yaw and box REP 103 (x = the object's front, radians); model and verification None "
      "without a fit.")
      .def_property_readonly(
          "cls", [](const PyDetection& d) { return ClassName(d.detection.furniture_class); })
      .def_property_readonly("x", [](const PyDetection& d) { return d.detection.x; })
      .def_property_readonly("y", [](const PyDetection& d) { return d.detection.y; })
      .def_property_readonly("z", [](const PyDetection& d) { return d.detection.z; })
      .def_property_readonly("yaw", [](const PyDetection& d) { return d.box.yaw; })
      .def_property_readonly("box", [](const PyDetection& d) { return BoxDict(d.box); })
      .def_property_readonly("model",
                             [](const PyDetection& d) -> py::object {
                               if (d.detection.model_index < 0) return py::none();
                               return py::str(d.detection.model_name);
                             })
      .def_property_readonly("score", [](const PyDetection& d) { return d.detection.score; })
      .def_property_readonly("vote_weight",
                             [](const PyDetection& d) { return d.detection.vote_weight; })
      .def_property_readonly("verification",
                             [](const PyDetection& d) -> py::object {
                               if (d.detection.model_index < 0) return py::none();
                               return py::float_(d.detection.verification);
                             })
      .def_property_readonly("covered_fraction",
                             [](const PyDetection& d) -> py::object {
                               if (d.detection.model_index < 0) return py::none();
                               return py::float_(d.detection.covered_fraction);
                             })
      .def_property_readonly("in_view", [](const PyDetection& d) { return d.detection.in_view; })
      .def("__repr__", [](const PyDetection& p) {
        char text[160];
        std::snprintf(text,
                      sizeof(text),
                      "<furnidet.Detection %s x=%.3f y=%.3f yaw=%.3f score=%.3f>",
                      ClassName(p.detection.furniture_class),
                      p.detection.x,
                      p.detection.y,
                      p.box.yaw,
                      p.detection.score);
        return std::string(text);
      });

  py::class_<PyResult>(m, "DetectionResult")
      .def_property_readonly("status", [](const PyResult& r) { return EnumName(r.result.status); })
      .def_property_readonly("message", [](const PyResult& r) { return r.result.message; })
      .def_readonly("detections", &PyResult::detections)
      .def_property_readonly("floor_estimated",
                             [](const PyResult& r) { return r.result.floor_estimated; })
      .def_property_readonly("points_in_range",
                             [](const PyResult& r) { return r.result.input_points; })
      .def_property_readonly("points", [](const PyResult& r) { return r.result.scene_points; })
      .def_property_readonly("segments", [](const PyResult& r) { return r.result.segments; })
      .def_property_readonly(
          "world_from_camera",
          [](const PyResult& r) { return MatrixArray(r.result.world_from_camera.matrix()); })
      .def_property_readonly("timings_ms", [](const PyResult& r) {
        py::dict timings;
        for (const StageTime& t : r.result.timings_ms.stages)
          timings[py::str(EnumName(t.stage))] = t.ms;
        return timings;
      });
}

}  // namespace
}  // namespace furn

PYBIND11_MODULE(_furnidet, m) {
  using namespace furn;
  m.doc() = "furnidet: furniture detection from web CAD models (compiled part)";
  // Our errors keep their one-line messages: a caller's mistake is a
  // ValueError, a database problem an OSError.
  static py::exception<InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<DbError> database_error(m, "DatabaseError", PyExc_OSError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      input_error(e.what());
    } catch (const DbError& e) {
      database_error(e.what());
    }
  });

  py::list classes;
  for (FurnitureClass c : kAllClasses) classes.append(ClassName(c));
  m.attr("CLASSES") = classes;

  BindDataset(m);
  BindDetections(m);

  py::class_<PyDetector>(m, "Detector", "A trained model ready to detect; loads once.")
      .def(py::init<const std::string&, const py::object&>(),
           py::arg("model"),
           py::arg("options") = py::none())
      .def("detect_depth",
           &PyDetector::DetectDepth,
           py::arg("depth"),
           py::arg("K"),
           py::arg("world_from_camera") = py::none(),
           py::arg("depth_scale") = py::none(),
           "Detect in a depth image: float metres, or integers in 1/depth_scale m (default mm).")
      .def("detect_points",
           &PyDetector::DetectPoints,
           py::arg("points"),
           py::arg("world_from_camera") = py::none(),
           "Detect in camera-frame points, (N, 3) or organised (H, W, 3), metres.")
      .def("detect_fused",
           &PyDetector::DetectFused,
           py::arg("scans"),
           py::arg("register") = false,
           py::arg("planar") = false,
           "Detect in several posed scans at once: a list of (points, world_from_camera) pairs, "
           "seen from the last one's camera; register=True refines their poses first "
           "(generalized ICP; with planar=True in x, y and yaw only, point-to-plane ICP).")
      .def_property_readonly("model_names", &PyDetector::ModelNames)
      .def_property_readonly(
          "vote_net_input",
          &PyDetector::VoteNetInput,
          "What the vote network was trained on: {'fused_share', 'pose_noise_m', "
          "'pose_noise_deg', 'planar'} (fused_share 0: single frames), or None (a codebook "
          "model, or a model file older than format 10). detect_fused detects best with a "
          "model trained fused (docs/detection.md).");

  m.def("evaluate",
        &EvaluateFromPython,
        py::arg("model"),
        py::arg("db"),
        py::arg("split") = "test",
        py::arg("max_frames") = 0,
        py::arg("label") = "",
        py::arg("options") = py::none(),
        "Evaluate a model on a dataset split as `workbench evaluate` does (the run is stored "
        "in the dataset); returns run_id, frames, seconds and metrics.");
}
