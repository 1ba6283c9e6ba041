// The model file (core/model/trained_model.h): one versioned binary file,
// its writer, and its bounds-checked reader with the upgrade path of
// LoadTrainedModelUnchecked.
#include <cmath>
#include <cstring>
#include <filesystem>

#include <xxhash.h>

#include "core/geometry/scan_fusion.h"  // CheckPoseErrorSpreads
#include "core/learned/vote_net.h"
#include "core/model/trained_model.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/text.h"

namespace furn {
namespace {

constexpr char kMagic[8] = {'F', 'U', 'R', 'N', 'M', 'D', 'L', '\0'};
constexpr uint32_t kFormatVersion = 10;  // 2: part-subset library and model shapes; 3: scorer;
                                         // 4: render meshes; 5: the part index stored;
                                         // 6: an XXH3-64 checksum of the payload at the end;
                                         // 7: the VFH size component flag; 8: vote network;
                                         // 9: the operating point; 10: the vote network's input
constexpr uint32_t kOldestReadable = 2;
constexpr size_t kHeaderBytes = 12;  // magic and version, outside the checksum

// Little-endian binary writer and a bounds-checked reader for the model file.
class Writer {
 public:
  void Bytes(const void* data, size_t size) { out_.append(static_cast<const char*>(data), size); }
  void U32(uint32_t v) { Bytes(&v, sizeof(v)); }
  void I32(int32_t v) { Bytes(&v, sizeof(v)); }
  void F64(double v) { Bytes(&v, sizeof(v)); }
  void F32(float v) { Bytes(&v, sizeof(v)); }
  void String(const std::string& s) {
    U32(static_cast<uint32_t>(s.size()));
    Bytes(s.data(), s.size());
  }
  void Vector(const Eigen::VectorXd& v) {
    U32(static_cast<uint32_t>(v.size()));
    Bytes(v.data(), v.size() * sizeof(double));
  }
  const std::string& bytes() const { return out_; }

 private:
  std::string out_;
};

class Reader {
 public:
  Reader(const char* bytes, size_t size, const std::string& path)
      : bytes_(bytes), size_(size), path_(path) {}
  void Bytes(void* data, size_t size) {
    if (size == 0) return;  // data may be null (an empty vector's)
    Require(size <= size_ - position_, path_ + ": model file is truncated");
    std::memcpy(data, bytes_ + position_, size);
    position_ += size;
  }
  template <class T>
  T Value() {
    T v;
    Bytes(&v, sizeof(v));
    return v;
  }
  uint32_t U32() { return Value<uint32_t>(); }
  int32_t I32() { return Value<int32_t>(); }
  double F64() { return Value<double>(); }
  float F32() { return Value<float>(); }
  // A count of items of at least `bytes_each` bytes: within `limit`, and no
  // more than the rest of the file can hold (nothing is allocated for items
  // the file does not have).
  uint32_t Count(uint32_t limit, size_t bytes_each = 1) {
    const uint32_t n = U32();
    Require(n <= limit && static_cast<uint64_t>(n) * bytes_each <= size_ - position_,
            path_ + ": model file is corrupt (a count of " + std::to_string(n) + ")");
    return n;
  }
  std::string String(uint32_t max_size = 1u << 20) {
    std::string s(Count(max_size), '\0');
    Bytes(s.data(), s.size());
    return s;
  }
  Eigen::VectorXd Vector() {
    Eigen::VectorXd v(Count(1u << 24));
    Bytes(v.data(), v.size() * sizeof(double));
    return v;
  }
  bool AtEnd() const { return position_ == size_; }
  // Reads stop at `end` (the checksum follows the payload).
  void Limit(size_t end) { size_ = std::min(size_, end); }

 private:
  const char* bytes_;
  size_t size_;
  const std::string& path_;
  size_t position_ = 0;
};

void WriteOptions(const TrainerOptions& o, Writer* w) {
  w->F64(o.preprocess.voxel_size_m);
  w->F64(o.preprocess.normal_radius_m);
  w->I32(o.preprocess.min_neighbours);
  w->F64(o.region_growing.delta_m);
  w->F64(o.region_growing.alpha_deg);
  w->I32(o.region_growing.min_segment_size);
  w->F64(o.sgf.voxel_size_m);
  w->F64(o.sgf.boundary_radius_m);
  w->F64(o.sgf.boundary_angle_deg);
  const VocabularyOptions& v = o.vocabulary;
  w->I32(static_cast<int32_t>(v.kind));
  w->I32(static_cast<int32_t>(v.rim_init));
  w->I32(v.words);
  w->I32(v.kmeans_restarts);
  w->I32(v.kmeans_iterations);
  w->F64(v.rim_lambda);
  w->I32(v.rim_iterations);
  w->I32(v.activated_words);
  w->F64(v.min_probability);
  w->Bytes(&v.seed, sizeof(v.seed));
  const PartSubsetOptions& p = o.part_subsets;
  w->I32(p.min_subset_size);
  w->I32(p.max_subset_size);
  w->I32(p.max_subsets_per_view);
  w->F64(p.adjacency_m);
  w->F64(o.shape_voxel_m);
}

TrainerOptions ReadOptions(Reader* r) {
  TrainerOptions o;
  o.preprocess.voxel_size_m = r->F64();
  o.preprocess.normal_radius_m = r->F64();
  o.preprocess.min_neighbours = r->I32();
  o.region_growing.delta_m = r->F64();
  o.region_growing.alpha_deg = r->F64();
  o.region_growing.min_segment_size = r->I32();
  o.sgf.voxel_size_m = r->F64();
  o.sgf.boundary_radius_m = r->F64();
  o.sgf.boundary_angle_deg = r->F64();
  VocabularyOptions& v = o.vocabulary;
  v.kind = static_cast<VocabularyKind>(r->I32());
  v.rim_init = static_cast<RimInit>(r->I32());
  v.words = r->I32();
  v.kmeans_restarts = r->I32();
  v.kmeans_iterations = r->I32();
  v.rim_lambda = r->F64();
  v.rim_iterations = r->I32();
  v.activated_words = r->I32();
  v.min_probability = r->F64();
  r->Bytes(&v.seed, sizeof(v.seed));
  PartSubsetOptions& p = o.part_subsets;
  p.min_subset_size = r->I32();
  p.max_subset_size = r->I32();
  p.max_subsets_per_view = r->I32();
  p.adjacency_m = r->F64();
  o.shape_voxel_m = r->F64();
  return o;
}

void WriteVector3(const Eigen::Vector3f& v, Writer* w) {
  for (int k = 0; k < 3; ++k) w->F32(v[k]);
}

Eigen::Vector3f ReadVector3(Reader* r) {
  Eigen::Vector3f v;
  for (int k = 0; k < 3; ++k) v[k] = r->F32();
  return v;
}

}  // namespace

namespace {

void WriteOperatingPoint(const OperatingPoint& point, Writer* w) {
  w->F64(point.match_m);
  w->String(point.chosen_on);
  for (const ClassOperatingPoint& c : point.classes) {
    w->F64(c.min_score);
    w->F64(c.precision);
    w->F64(c.recall);
    w->F64(c.f1);
    w->I32(c.targets);
  }
}

void WriteVoteNetInput(const VoteNetInput& input, Writer* w) {
  w->F64(input.recorded ? input.fused_share : -1);  // -1: an upgraded older file's unknown
  w->F64(input.pose_noise_m);
  w->F64(input.pose_noise_deg);
  w->I32(input.planar ? 1 : 0);
}

}  // namespace

void SaveTrainedModel(const TrainedModel& model, const std::string& path) {
  Writer w;
  w.Bytes(kMagic, sizeof(kMagic));
  w.U32(kFormatVersion);
  WriteOptions(model.options, &w);
  w.U32(static_cast<uint32_t>(model.model_names.size()));
  for (size_t i = 0; i < model.model_names.size(); ++i) {
    w.String(model.model_names[i]);
    w.I32(static_cast<int32_t>(model.model_classes[i]));
  }
  w.Bytes(model.normalizer.low.data(), sizeof(double) * kSgfCount);
  w.Bytes(model.normalizer.high.data(), sizeof(double) * kSgfCount);
  const Vocabulary::State state = model.vocabulary.GetState();
  w.I32(static_cast<int32_t>(state.kind));
  w.I32(state.activated_words);
  w.F64(state.min_probability);
  w.I32(state.used_words);
  w.U32(static_cast<uint32_t>(state.centres.size()));
  for (const Eigen::VectorXd& c : state.centres) w.Vector(c);
  w.U32(static_cast<uint32_t>(state.weights.rows()));
  for (Eigen::Index r = 0; r < state.weights.rows(); ++r)
    w.Vector(state.weights.row(r).transpose());
  w.Vector(state.biases);
  w.I32(model.training_segments);
  w.U32(static_cast<uint32_t>(model.shape.size()));
  for (const ShapeEntry& e : model.shape) {
    w.I32(e.word);
    w.F64(e.probability);
    w.I32(static_cast<int32_t>(e.furniture_class));
    w.I32(e.model_index);
    w.F32(e.relation.x());
    w.F32(e.relation.y());
    w.F32(e.height);
  }
  for (const ModelShape& shape : model.model_shapes) {
    w.U32(static_cast<uint32_t>(shape.points.size()));
    for (size_t i = 0; i < shape.points.size(); ++i) {
      WriteVector3(shape.points[i], &w);
      WriteVector3(shape.normals[i], &w);
    }
    WriteVector3(shape.low, &w);
    WriteVector3(shape.high, &w);
  }
  w.U32(static_cast<uint32_t>(model.part_models.size()));
  for (int m : model.part_models) w.I32(m);
  const PartSubsetIndex::State& index = model.part_index;
  Require(index.projected.rows() == static_cast<Eigen::Index>(model.part_models.size()),
          "a trained model needs one indexed part subset per part model");
  w.U32(static_cast<uint32_t>(model.part_models.empty() ? 0 : index.basis.cols()));
  if (!model.part_models.empty()) w.Bytes(index.mean.data(), sizeof(float) * index.mean.size());
  w.Bytes(index.basis.data(), sizeof(float) * index.basis.size());
  w.Bytes(index.projected.data(), sizeof(float) * index.projected.size());
  w.String(model.scorer);
  Require(model.render_meshes.empty() || model.render_meshes.size() == model.model_names.size(),
          "a trained model needs one render mesh per CAD model, or none");
  w.U32(static_cast<uint32_t>(model.render_meshes.size()));
  for (const TriangleMesh& mesh : model.render_meshes) {
    w.U32(static_cast<uint32_t>(mesh.vertices.size()));
    for (const Eigen::Vector3f& v : mesh.vertices) WriteVector3(v, &w);
    w.U32(static_cast<uint32_t>(mesh.triangles.size()));
    w.Bytes(mesh.triangles.data(), sizeof(int) * 3 * mesh.triangles.size());
  }
  w.I32(model.options.part_subsets.vfh_size_component ? 1 : 0);
  w.String(model.vote_net);
  WriteOperatingPoint(model.operating_point, &w);
  WriteVoteNetInput(model.vote_net_input, &w);
  const std::string& bytes = w.bytes();
  const uint64_t checksum = XXH3_64bits(bytes.data() + kHeaderBytes, bytes.size() - kHeaderBytes);
  w.Bytes(&checksum, sizeof(checksum));
  WriteFileAtomically(path, w.bytes());
}

namespace {

// A vocabulary's state as training makes it: a known kind, centres or
// weight rows of one length (the features' count), a bias per weight row.
void CheckVocabularyState(const Vocabulary::State& state,
                          const std::vector<Eigen::VectorXd>& weight_rows,
                          const std::string& path) {
  const std::string corrupt = path + ": model file is corrupt (the vocabulary's ";
  Require(state.kind == VocabularyKind::kKMeans || state.kind == VocabularyKind::kRim,
          corrupt + "kind " + std::to_string(static_cast<int>(state.kind)) +
              " is neither 0 (k-means) nor 1 (RIM))");
  for (const Eigen::VectorXd& centre : state.centres)
    Require(centre.size() == kSgfCount && centre.allFinite(),
            corrupt + "centres are not " + std::to_string(kSgfCount) + " finite numbers each)");
  for (const Eigen::VectorXd& row : weight_rows)
    Require(row.size() == kSgfCount && row.allFinite(),
            corrupt + "weight rows are not " + std::to_string(kSgfCount) + " finite numbers each)");
  Require(state.biases.size() == static_cast<Eigen::Index>(weight_rows.size()) &&
              state.biases.allFinite(),
          corrupt + "biases do not match its weight rows)");
  Require(std::isfinite(state.min_probability) && state.min_probability >= 0 &&
              state.min_probability <= 1,
          corrupt + "least probability is not in 0..1)");
  Require(state.activated_words >= 0 && state.activated_words <= 100000 && state.used_words >= 0 &&
              state.used_words <= 100000,
          corrupt + "word counts are not in 0..100000)");
}

Vocabulary ReadVocabulary(Reader* r, const std::string& path) {
  Vocabulary::State state;
  state.kind = static_cast<VocabularyKind>(r->I32());
  state.activated_words = r->I32();
  state.min_probability = r->F64();
  state.used_words = r->I32();
  const uint32_t centres = r->Count(100000);
  for (uint32_t i = 0; i < centres; ++i) state.centres.push_back(r->Vector());
  const uint32_t rows = r->Count(100000);
  std::vector<Eigen::VectorXd> weight_rows;
  for (uint32_t i = 0; i < rows; ++i) weight_rows.push_back(r->Vector());
  state.biases = r->Vector();
  CheckVocabularyState(state, weight_rows, path);
  state.weights.resize(rows, rows > 0 ? weight_rows[0].size() : 0);
  for (uint32_t i = 0; i < rows; ++i) state.weights.row(i) = weight_rows[i].transpose();
  return Vocabulary::FromState(state);
}

std::vector<ShapeEntry> ReadShapeEntries(Reader* r) {
  std::vector<ShapeEntry> shape(r->Count(1u << 28, 32));
  for (ShapeEntry& e : shape) {
    e.word = r->I32();
    e.probability = r->F64();
    e.furniture_class = static_cast<FurnitureClass>(r->I32());
    e.model_index = r->I32();
    e.relation.x() = r->F32();
    e.relation.y() = r->F32();
    e.height = r->F32();
  }
  return shape;
}

// A model shape's points are a piece of furniture in its own frame: finite,
// within kMaxShapeExtentM of its origin, and the stored bounds
// exactly their bounding box (the fitter sizes its grids by them).
constexpr float kMaxShapeExtentM = 20;

void CheckModelShape(const ModelShape& shape, size_t index, const std::string& path) {
  const std::string corrupt =
      path + ": model file is corrupt (model shape " + std::to_string(index) + "'s ";
  Eigen::Vector3f low = Eigen::Vector3f::Zero(), high = Eigen::Vector3f::Zero();
  for (size_t i = 0; i < shape.points.size(); ++i) {
    const Eigen::Vector3f& p = shape.points[i];
    Require(p.allFinite() && p.cwiseAbs().maxCoeff() <= kMaxShapeExtentM,
            corrupt + "point " + std::to_string(i) + " is not finite within " +
                std::to_string(static_cast<int>(kMaxShapeExtentM)) + " m)");
    low = i == 0 ? p : low.cwiseMin(p);
    high = i == 0 ? p : high.cwiseMax(p);
  }
  Require(shape.low.allFinite() && shape.high.allFinite() && shape.low == low && shape.high == high,
          corrupt + "bounds are not its points' bounding box)");
}

void ReadModelShapes(Reader* r, std::vector<ModelShape>* shapes, const std::string& path) {
  std::vector<float> interleaved;
  for (size_t k = 0; k < shapes->size(); ++k) {
    ModelShape& shape = (*shapes)[k];
    shape.points.resize(r->Count(1u << 26, 24));
    shape.normals.resize(shape.points.size());
    interleaved.resize(6 * shape.points.size());
    r->Bytes(interleaved.data(), sizeof(float) * interleaved.size());
    for (size_t i = 0; i < shape.points.size(); ++i) {
      shape.points[i] = Eigen::Map<const Eigen::Vector3f>(&interleaved[6 * i]);
      shape.normals[i] = Eigen::Map<const Eigen::Vector3f>(&interleaved[6 * i + 3]);
    }
    shape.low = ReadVector3(r);
    shape.high = ReadVector3(r);
    CheckModelShape(shape, k, path);
  }
}

// The part subsets' models and their descriptor index: as trained (version
// 5 on), or raw descriptors indexed now.
void ReadPartIndex(
    Reader* r, uint32_t version, size_t file_size, const std::string& path, TrainedModel* model) {
  const uint32_t parts = r->Count(1u << 26, 4);
  model->part_models.resize(parts);
  constexpr int kBins = static_cast<int>(std::tuple_size<VfhDescriptor>::value);
  if (version >= 5) {  // the index as trained
    r->Bytes(model->part_models.data(), sizeof(int) * parts);
    const uint32_t dimensions = r->Count(kBins);
    Require(static_cast<uint64_t>(dimensions) * (kBins + parts) * sizeof(float) <= file_size,
            path + ": model file is corrupt (a part index larger than the file)");
    Require((dimensions >= 1) == (parts >= 1),
            path + ": model file is corrupt (a part index of no dimensions)");
    PartSubsetIndex::State& index = model->part_index;
    if (parts > 0) {  // a model without part subsets has no index (tests)
      index.mean.resize(kBins);
      index.basis.resize(kBins, dimensions);
      index.projected.resize(parts, dimensions);
      r->Bytes(index.mean.data(), sizeof(float) * index.mean.size());
      r->Bytes(index.basis.data(), sizeof(float) * index.basis.size());
      r->Bytes(index.projected.data(), sizeof(float) * index.projected.size());
    }
  } else {  // raw descriptors: index them now
    std::vector<VfhDescriptor> descriptors(parts);
    for (uint32_t i = 0; i < parts; ++i) {
      model->part_models[i] = r->I32();
      r->Bytes(descriptors[i].data(), sizeof(float) * kBins);
    }
    if (parts > 0) model->part_index = PartSubsetIndex(descriptors).state();
  }
  for (int m : model->part_models) {
    Require(m >= 0 && m < static_cast<int>(model->model_names.size()),
            path + ": model file is corrupt (a part subset names no model)");
  }
}

std::vector<TriangleMesh> ReadRenderMeshes(Reader* r, size_t models, const std::string& path) {
  const uint32_t meshes = r->Count(100000);
  Require(meshes == 0 || meshes == models,
          path + ": model file is corrupt (render meshes do not match the models)");
  std::vector<TriangleMesh> render_meshes(meshes);
  for (TriangleMesh& mesh : render_meshes) {
    mesh.vertices.resize(r->Count(1u << 26, 12));
    r->Bytes(mesh.vertices.data(), sizeof(float) * 3 * mesh.vertices.size());
    mesh.triangles.resize(r->Count(1u << 26, 12));
    r->Bytes(mesh.triangles.data(), sizeof(int) * 3 * mesh.triangles.size());
    for (const Eigen::Vector3i& t : mesh.triangles) {
      Require((t.array() >= 0).all() && (t.array() < static_cast<int>(mesh.vertices.size())).all(),
              path + ": model file is corrupt (a render mesh triangle indexes no vertex)");
    }
  }
  return render_meshes;
}

// Every index the detector follows is in range.
void CheckIndices(const TrainedModel& model, const std::string& path) {
  const std::string corrupt = path + ": model file is corrupt (";
  for (FurnitureClass c : model.model_classes) {
    Require(static_cast<int>(c) >= 0 && static_cast<size_t>(c) < kAllClasses.size(),
            corrupt + "a model of no known class)");
  }
  const int words = model.vocabulary.NumWords();
  for (const ShapeEntry& e : model.shape) {
    Require(e.word >= 0 && e.word < words && static_cast<int>(e.furniture_class) >= 0 &&
                static_cast<size_t>(e.furniture_class) < kAllClasses.size() && e.model_index >= 0 &&
                e.model_index < static_cast<int>(model.model_names.size()),
            corrupt + "a shape entry indexes no word, class or model)");
  }
}

OperatingPoint ReadOperatingPoint(Reader* r, const std::string& path) {
  const std::string corrupt = path + ": model file is corrupt (the operating point's ";
  OperatingPoint point;
  point.match_m = r->F64();
  Require(point.match_m > 0 && point.match_m <= 2, corrupt + "match distance is not in (0, 2] m)");
  point.chosen_on = r->String(4096);
  Require(IsValidUtf8(point.chosen_on), corrupt + "note of where it was chosen is not UTF-8)");
  for (ClassOperatingPoint& c : point.classes) {
    c.min_score = r->F64();
    c.precision = r->F64();
    c.recall = r->F64();
    c.f1 = r->F64();
    c.targets = r->I32();
    Require(c.min_score == -1 || (c.min_score >= 0 && c.min_score <= 1),
            corrupt + "threshold is neither -1 nor in 0..1)");
    for (double share : {c.precision, c.recall, c.f1})
      Require(std::isnan(share) || (share >= 0 && share <= 1),
              corrupt + "precision, recall or F1 is not in 0..1)");
    Require(c.targets >= 0, corrupt + "object count is negative)");
  }
  return point;
}

// Within the ranges `train` accepts (train_vote_net.cc's checks).
VoteNetInput ReadVoteNetInput(Reader* r, const std::string& path) {
  const std::string corrupt = path + ": model file is corrupt (the vote network's training input ";
  VoteNetInput input;
  input.fused_share = r->F64();
  input.pose_noise_m = r->F64();
  input.pose_noise_deg = r->F64();
  const int32_t planar = r->I32();
  input.recorded = input.fused_share != -1;
  if (!input.recorded) input.fused_share = 0;
  Require(planar == 0 || planar == 1, corrupt + "planar flag is neither 0 nor 1)");
  input.planar = planar == 1;
  try {
    input.Check();
  } catch (const InputError& e) {
    throw InputError(corrupt + e.what() + ")");
  }
  return input;
}

// The magic, the format version, and (version 6 on) the checksum over the
// payload, checked before anything is parsed; returns the version.
uint32_t ReadHeader(const MappedFile& file, const std::string& path, Reader* r) {
  char magic[sizeof(kMagic)] = {};
  Require(file.size() >= sizeof(kMagic), path + ": not a furnidet model file");
  r->Bytes(magic, sizeof(magic));
  Require(std::memcmp(magic, kMagic, sizeof(kMagic)) == 0, path + ": not a furnidet model file");
  const uint32_t version = r->U32();
  Require(version >= kOldestReadable && version <= kFormatVersion,
          path + ": model file format version " + std::to_string(version) +
              " is not the version this build reads (" + std::to_string(kFormatVersion) +
              "); train it again");
  if (version >= 6) {  // a damaged file stops here, before anything is parsed
    Require(file.size() >= kHeaderBytes + sizeof(uint64_t), path + ": model file is truncated");
    const size_t payload_end = file.size() - sizeof(uint64_t);
    uint64_t stored = 0;
    std::memcpy(&stored, file.data() + payload_end, sizeof(stored));
    Require(XXH3_64bits(file.data() + kHeaderBytes, payload_end - kHeaderBytes) == stored,
            path + ": model file is damaged (checksum mismatch); train it again or copy it anew");
    r->Limit(payload_end);
  }
  return version;
}

}  // namespace

TrainedModel LoadTrainedModel(const std::string& path) {
  TrainedModel model = LoadTrainedModelUnchecked(path);
  // The vote network's block checked here, so that its refusal names the
  // file (a TorchScript block of formats 2 and 3 is refused unread).
  if (!model.vote_net.empty()) VoteNet::Deserialize(model.vote_net, path + " (its vote network)");
  return model;
}

TrainedModel LoadTrainedModelUnchecked(const std::string& path) {
  Require(!std::filesystem::is_directory(path), path + ": cannot read (is a directory)");
  const MappedFile file(path);
  Reader r(file.data(), file.size(), path);
  const uint32_t version = ReadHeader(file, path, &r);
  TrainedModel model;
  model.options = ReadOptions(&r);
  const uint32_t models = r.Count(100000, 8);
  for (uint32_t i = 0; i < models; ++i) {
    model.model_names.push_back(r.String());
    model.model_classes.push_back(static_cast<FurnitureClass>(r.I32()));
    Require(IsValidUtf8(model.model_names.back()),
            path + ": model file is corrupt (CAD model name " + std::to_string(i) + " '" +
                PrintableText(model.model_names.back()) + "' is not valid UTF-8)");
  }
  r.Bytes(model.normalizer.low.data(), sizeof(double) * kSgfCount);
  r.Bytes(model.normalizer.high.data(), sizeof(double) * kSgfCount);
  model.vocabulary = ReadVocabulary(&r, path);
  model.training_segments = r.I32();
  model.shape = ReadShapeEntries(&r);
  model.model_shapes.resize(model.model_names.size());
  ReadModelShapes(&r, &model.model_shapes, path);
  ReadPartIndex(&r, version, file.size(), path, &model);
  if (version >= 3) model.scorer = r.String(1u << 28);
  if (version >= 4) model.render_meshes = ReadRenderMeshes(&r, model.model_names.size(), path);
  if (version >= 7) {
    const int32_t size_component = r.I32();
    Require(size_component == 0 || size_component == 1,
            path + ": model file is corrupt (the VFH size component flag is neither 0 nor 1)");
    model.options.part_subsets.vfh_size_component = size_component == 1;
  }
  if (version >= 8) model.vote_net = r.String(1u << 28);
  if (version >= 9) model.operating_point = ReadOperatingPoint(&r, path);
  model.vote_net_input = version >= 10 ? ReadVoteNetInput(&r, path) : VoteNetInput{};
  Require(r.AtEnd(), path + ": model file has trailing bytes (corrupt)");
  try {
    model.options.Check();
  } catch (const InputError& e) {
    throw InputError(path + ": model file's trainer options are out of range (" + e.what() + ")");
  }
  CheckIndices(model, path);
  return model;
}

void VoteNetInput::Check() const {
  Require(std::isfinite(fused_share) && fused_share >= 0 && fused_share <= 1,
          "fused share " + std::to_string(fused_share) + " must be in 0..1");
  CheckPoseErrorSpreads(pose_noise_m, pose_noise_deg, "fused pose error");
  Require(fused_share > 0 || (pose_noise_m == 0 && pose_noise_deg == 0 && !planar),
          "a fused pose error needs a fused share above 0");
}

}  // namespace furn
