#include "workbench/formats/options_file.h"

#include <functional>
#include <nlohmann/json.hpp>
#include <vector>

#include "core/util/error.h"
#include "workbench/formats/detector_option_table.h"
#include "workbench/formats/json_text.h"

namespace furn {
namespace {

using Json = nlohmann::ordered_json;

// One option: its dotted path in its section ("trainer" or "detector"), how
// to read it from the options and how to set it from JSON (throws nlohmann's
// type_error for a wrong type).
struct Field {
  std::string path;
  std::function<Json()> get;
  std::function<void(const nlohmann::json&)> set;
};

template <typename T>
Field Plain(const std::string& path, T* value) {
  if constexpr (std::is_enum_v<T>) {  // spelled as its EnumText name
    return {path,
            [value] { return Json(EnumName(*value)); },
            [value, path](const nlohmann::json& j) {
              Require(j.is_string(), "'" + path + "' must be one of " + EnumNameList<T>());
              *value = ParseEnum<T>(j.get<std::string>());
            }};
  } else {
    return {path,
            [value] { return Json(*value); },
            [value](const nlohmann::json& j) { *value = j.get<T>(); }};
  }
}

// A two-valued enum spelled as text.
template <typename E>
Field Named(const std::string& path,
            E* value,
            E first,
            const char* first_name,
            E second,
            const char* second_name) {
  return {path,
          [=] { return Json(*value == first ? first_name : second_name); },
          [=](const nlohmann::json& j) {
            const std::string name = j.get<std::string>();
            if (name != first_name && name != second_name) {
              throw InputError("'" + path + "' must be \"" + first_name + "\" or \"" + second_name +
                               "\", not \"" + name + "\"");
            }
            *value = name == first_name ? first : second;
          }};
}

std::vector<Field> FieldsOf(TrainingOptions* o) {
  TrainerOptions& t = o->trainer;
  ScanOptions& s = o->scan;
  return {
      Plain("preprocess.voxel_size_m", &t.preprocess.voxel_size_m),
      Plain("preprocess.normal_radius_m", &t.preprocess.normal_radius_m),
      Plain("preprocess.min_neighbours", &t.preprocess.min_neighbours),
      Plain("region_growing.delta_m", &t.region_growing.delta_m),
      Plain("region_growing.alpha_deg", &t.region_growing.alpha_deg),
      Plain("region_growing.min_segment_size", &t.region_growing.min_segment_size),
      Plain("sgf.voxel_size_m", &t.sgf.voxel_size_m),
      Plain("sgf.boundary_radius_m", &t.sgf.boundary_radius_m),
      Plain("sgf.boundary_angle_deg", &t.sgf.boundary_angle_deg),
      Named("vocabulary.kind",
            &t.vocabulary.kind,
            VocabularyKind::kRim,
            "rim",
            VocabularyKind::kKMeans,
            "kmeans"),
      Named("vocabulary.rim_init",
            &t.vocabulary.rim_init,
            RimInit::kKMeans,
            "kmeans",
            RimInit::kPcaSplit,
            "pca"),
      Plain("vocabulary.words", &t.vocabulary.words),
      Plain("vocabulary.kmeans_restarts", &t.vocabulary.kmeans_restarts),
      Plain("vocabulary.kmeans_iterations", &t.vocabulary.kmeans_iterations),
      Plain("vocabulary.rim_lambda", &t.vocabulary.rim_lambda),
      Plain("vocabulary.rim_iterations", &t.vocabulary.rim_iterations),
      Plain("vocabulary.activated_words", &t.vocabulary.activated_words),
      Plain("vocabulary.min_probability", &t.vocabulary.min_probability),
      Plain("vocabulary.seed", &t.vocabulary.seed),
      Plain("part_subsets.min_subset_size", &t.part_subsets.min_subset_size),
      Plain("part_subsets.max_subset_size", &t.part_subsets.max_subset_size),
      Plain("part_subsets.max_subsets_per_view", &t.part_subsets.max_subsets_per_view),
      Plain("part_subsets.adjacency_m", &t.part_subsets.adjacency_m),
      Plain("part_subsets.vfh_size_component", &t.part_subsets.vfh_size_component),
      Plain("shape_voxel_m", &t.shape_voxel_m),
      Plain("scan.heights_m", &s.heights_m),
      Plain("scan.azimuths", &s.azimuths),
      Plain("scan.min_distance_m", &s.min_distance_m),
      Plain("scan.max_distance_m", &s.max_distance_m),
      Plain("scan.seed", &s.seed),
      Plain("scan.scale_variants", &s.scale_variants),
      Plain("scan.scale_jitter", &s.scale_jitter),
  };
}

// Every detector option, in the order runs store them (detector_option_table.h).
std::vector<Field> FieldsOf(DetectorOptions* o) {
  std::vector<Field> fields;
  ForEachDetectorOption(o, [&fields](const DetectorOptionInfo& info, auto& value) {
    fields.push_back(Plain(info.key, &value));
  });
  return fields;
}

// "a.b.c" -> json["a"]["b"]["c"], created on the way.
Json& At(Json* root, const std::string& path) {
  Json* node = root;
  size_t start = 0;
  for (;;) {
    const size_t dot = path.find('.', start);
    node = &(*node)[path.substr(start, dot - start)];
    if (dot == std::string::npos) return *node;
    start = dot + 1;
  }
}

// Every leaf of `json` as (dotted path, value); arrays are leaves.
void Flatten(const nlohmann::json& json,
             const std::string& prefix,
             std::vector<std::pair<std::string, nlohmann::json>>* out) {
  for (const auto& [key, value] : json.items()) {
    if (value.is_object()) {
      Flatten(value, prefix + key + ".", out);
    } else {
      out->emplace_back(prefix + key, value);
    }
  }
}

// Every field, nested by its path.
std::string FieldsJson(const std::vector<Field>& fields) {
  Json json = Json::object();
  for (const Field& field : fields) At(&json, field.path) = field.get();
  return json.dump();
}

// Sets the fields `json` names; `section` ("trainer", "detector") names the
// options in errors: unknown keys and wrong types.
void SetFields(const nlohmann::json& json,
               const std::vector<Field>& fields,
               const std::string& section,
               const std::string& what) {
  std::vector<std::pair<std::string, nlohmann::json>> leaves;
  Flatten(json, "", &leaves);
  for (const auto& [path, value] : leaves) {
    const Field* field = nullptr;
    for (const Field& f : fields) {
      if (f.path == path) field = &f;
    }
    Require(field != nullptr, what + ": unknown " + section + " option '" + path + "'");
    try {
      field->set(value);
    } catch (const nlohmann::json::exception&) {
      throw InputError(what + ": " + section + " option '" + path + "' has the wrong type");
    } catch (const InputError& error) {
      throw InputError(what + ": " + section + " option " + error.what());
    }
  }
}

}  // namespace

std::string TrainingOptionsJson(const TrainingOptions& options) {
  TrainingOptions copy = options;
  return FieldsJson(FieldsOf(&copy));
}

std::string DetectorOptionsJson(const DetectorOptions& options) {
  DetectorOptions copy = options;
  return FieldsJson(FieldsOf(&copy));
}

DetectorOptions DetectorOptionsFromJson(const std::string& text, const std::string& what) {
  nlohmann::json json = nlohmann::json(ParseUserJson(text, what));
  // A whole options file's "trainer" is checked too, though detection does
  // not use it: a typo there must not pass here and fail only in `train`.
  if (json.is_object() && json.contains("trainer")) TrainingOptionsFromJson(text, what);
  // A run's options_json or an options file: its "detector" object (absent
  // in a trainer-only file: the defaults).
  if (json.is_object() && (json.contains("detector") || json.contains("trainer")))
    json = json.contains("detector") ? json["detector"] : nlohmann::json::object();
  Require(json.is_object(), what + ": detector options must be a JSON object");
  DetectorOptions options;
  SetFields(json, FieldsOf(&options), "detector", what);
  try {
    options.Check();
  } catch (const InputError& error) {
    throw InputError(what + ": " + error.what());
  }
  return options;
}

TrainingOptions TrainingOptionsFromJson(const std::string& text, const std::string& what) {
  nlohmann::json json = nlohmann::json(ParseUserJson(text, what));
  Require(json.is_object(), what + ": options must be a JSON object");
  if (json.contains("detector") || json.contains("trainer")) {
    Require(json.contains("trainer"),
            what + ": has no \"trainer\" options (a detector-only file cannot train)");
    json = json["trainer"];
    Require(json.is_object(), what + ": \"trainer\" must be a JSON object");
  }
  TrainingOptions options;
  SetFields(json, FieldsOf(&options), "trainer", what);
  try {
    options.trainer.Check();
    options.scan.Check();
  } catch (const InputError& error) {
    throw InputError(what + ": " + error.what());
  }
  return options;
}

std::string OptionsFileJson(const TrainingOptions& training, const DetectorOptions& detector) {
  const Json json{{"trainer", Json::parse(TrainingOptionsJson(training))},
                  {"detector", Json::parse(DetectorOptionsJson(detector))}};
  return json.dump(2) + "\n";
}

}  // namespace furn
