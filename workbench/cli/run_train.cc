#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <set>
#include <tuple>

#include "core/codebook/hypothesis_scorer.h"
#include "core/codebook/trainer.h"
#include "core/learned/vote_net.h"
#include "core/learned/vote_net_upgrade.h"
#include "core/model/trained_model.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/parallel.h"
#include "db/dataset_db.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/cluster_flags.h"
#include "workbench/cli/commands.h"
#include "workbench/cli/detector_flags.h"
#include "workbench/formats/options_file.h"
#include "workbench/pipelines/eval_parts.h"
#include "workbench/pipelines/evaluate.h"
#include "workbench/pipelines/generate.h"  // ParseShard
#include "workbench/pipelines/model_info.h"
#include "workbench/pipelines/train.h"

namespace furn {
namespace {

// What training made and how long each stage took.
void PrintTrainSummary(const std::string& out,
                       const TrainerOptions& trainer,
                       const TrainSummary& summary) {
  std::printf(
      "wrote %s: %d models, %d views, %d segments, %d of %d words used; scans %.1f s, training "
      "%.1f s\n",
      out.c_str(),
      summary.models,
      summary.views,
      summary.segments,
      summary.used_words,
      trainer.vocabulary.words,
      summary.scan_s,
      summary.train_s);
  std::printf(
      "  training stages (s): segmentation + features %.1f, part subsets + VFH %.1f, "
      "vocabulary %.1f, shape model %.1f\n",
      summary.stages.segment_s,
      summary.stages.part_subsets_s,
      summary.stages.vocabulary_s,
      summary.stages.shape_s);
  if (summary.vote_net) {
    const VoteNetTrainingSummary& v = summary.vote_net_training;
    std::printf(
        "  vote net: %d rooms, %d frames (%d objects), %d validation frames, %lld parameters "
        "(%s); generate %.1f s, rasterise %.1f s, train %.1f s; validation loss %.3f\n",
        v.rooms,
        v.frames,
        v.objects,
        v.validation_frames,
        static_cast<long long>(v.parameters),
        EnumName(v.precision),
        v.generate_s,
        v.raster_s,
        v.train_s,
        v.epochs.empty() ? 0.0 : v.epochs.back().validation_loss);
    std::printf("  vote net stages (s): %s\n", v.stages.Text().c_str());
    if (!v.member_validation_maps.empty() && v.validation_frames > 0) {
      std::printf("  vote net: an ensemble of %zu networks, validation mAP@10cm %.3f (members %.3f",
                  v.member_validation_maps.size() + 1,
                  v.ensemble_validation_map,
                  v.epochs.back().validation_map);
      for (double map : v.member_validation_maps) std::printf(", %.3f", map);
      std::printf(")\n");
    } else if (!v.member_validation_maps.empty()) {
      std::printf("  vote net: an ensemble of %zu networks (no validation rooms)\n",
                  v.member_validation_maps.size() + 1);
    }
    if (v.vote_net_only_models > 0)
      std::printf("  vote net rooms also place the class map's %d vote-net-only models\n",
                  v.vote_net_only_models);
    if (v.rooms_reused > 0)
      std::printf("  vote net rooms: %d of %d from the rooms cache (%s)\n",
                  v.rooms_reused,
                  v.rooms,
                  v.rooms_path.c_str());
    std::printf("  %s", DescribeOperatingPoint(v.operating_point).c_str());
  }
}

// Data-parallel training of the vote network (issue 70): --vote-workers N
// processes of this machine, or with --slurm the N tasks of one Slurm job
// (--nodes M); the workers' own (hidden) flags, which rank 0 appends to the
// command it starts them with, and the Slurm tasks' group folder.
struct VoteWorkerFlags {
  int workers = 1;
  int nodes = 0;
  int rank = 0, of = 1;
  std::string store, rooms;
  std::string slurm_group;  // a Slurm task: its rank from SLURM_PROCID

  void Add(CLI::App* app) {
    app->add_option("--vote-workers",
                    workers,
                    "Train the vote network in N processes together (data-parallel, gradients "
                    "summed every step; each uses --vote-threads, 1 unless given): on this "
                    "machine, or with --slurm as the N tasks of one Slurm job")
        ->capture_default_str();
    app->add_option("--nodes",
                    nodes,
                    "With --vote-workers N and --slurm: spread the N training tasks over this "
                    "many nodes (0: where Slurm places them)")
        ->capture_default_str();
    app->add_option("--vote-worker-rank", rank)->group("");
    app->add_option("--vote-worker-of", of)->group("");
    app->add_option("--vote-worker-store", store)->group("");
    app->add_option("--vote-worker-rooms", rooms)->group("");
    app->add_option("--vote-slurm-group", slurm_group)->group("");
  }

  void Check(const ClusterFlags& cluster) const {
    Require(workers >= 1 && workers <= 64,
            "--vote-workers " + std::to_string(workers) + " must be in 1..64");
    Require(nodes == 0 || (cluster.Active() && workers > 1),
            "--nodes spreads the --vote-workers of a --slurm training over nodes; give both");
    Require(nodes >= 0 && nodes <= workers,
            "--nodes " + std::to_string(nodes) + " must be in 0.." + std::to_string(workers) +
                " (at most one node per --vote-workers task)");
  }

  // A Slurm task of the training: this process's rank and the group's
  // store (in the job's group folder, by the job's id: a rerun never meets
  // an earlier job's store).
  DataParallelOptions SlurmTask() const {
    DataParallelOptions group;
    group.rank = SlurmNumber("SLURM_PROCID", std::nullopt);
    group.world = SlurmNumber("SLURM_NTASKS", 1);
    Require(group.world == workers,
            "this Slurm job has " + std::to_string(group.world) + " tasks, --vote-workers " +
                std::to_string(workers) + " (submit it with 'train --vote-workers N --slurm')");
    std::filesystem::create_directories(slurm_group);
    group.store_path = slurm_group + "/store-" + std::to_string(SlurmNumber("SLURM_JOB_ID", 0));
    group.local = false;
    return group;
  }
  bool IsWorker() const {
    return rank > 0 || !store.empty() || (!slurm_group.empty() && SlurmTask().rank > 0);
  }

  // A worker's options: the group's, and one process each.
  VoteNetTrainingOptions Worker(const VoteNetTrainingOptions& vote_net, bool threads_given) const {
    VoteNetTrainingOptions options = vote_net;
    options.threads = Threads(vote_net.threads, threads_given);
    options.workers = 1;
    options.worker_command.clear();
    options.quiet = true;
    if (!slurm_group.empty()) {
      options.data_parallel = SlurmTask();
      return options;
    }
    Require(rank > 0 && !store.empty() && !rooms.empty(),
            "--vote-worker-rank, --vote-worker-store and --vote-worker-rooms go together");
    options.data_parallel.rank = rank;
    options.data_parallel.world = of;
    options.data_parallel.store_path = store;
    return options;
  }

  // Rank 0's options: the workers and the command that starts them (this
  // program with the same arguments), or the Slurm job's group it leads.
  VoteNetTrainingOptions Leader(const VoteNetTrainingOptions& vote_net,
                                bool threads_given,
                                int argc,
                                char** argv) const {
    VoteNetTrainingOptions options = vote_net;
    if (workers < 2) return options;
    options.threads = Threads(vote_net.threads, threads_given);
    if (!slurm_group.empty()) {
      options.data_parallel = SlurmTask();
      return options;
    }
    options.workers = workers;
    options.worker_command = {std::filesystem::read_symlink("/proc/self/exe").string()};
    for (int i = 0; i < argc; ++i) options.worker_command.push_back(argv[i]);
    options.worker_command.push_back("--quiet");
    return options;
  }

 private:
  // Each rank's torch threads: --vote-threads when given, else a Slurm
  // task's CPUs, else 1 (the local ranks share this machine's cores).
  int Threads(int given, bool threads_given) const {
    if (threads_given) return given;
    if (slurm_group.empty()) return 1;
    return std::clamp(SlurmNumber("SLURM_CPUS_PER_TASK", 1), 1, 256);
  }

  // A Slurm variable's value, checked; `fallback` when it is unset (none:
  // this is not a Slurm task).
  static int SlurmNumber(const char* name, std::optional<int> fallback) {
    const char* value = std::getenv(name);
    if (value == nullptr) {
      Require(
          fallback.has_value(),
          std::string("--vote-slurm-group runs in a task of a Slurm job (") + name + " is unset)");
      return *fallback;
    }
    char* end = nullptr;
    const long number = std::strtol(value, &end, 10);
    Require(*value != '\0' && *end == '\0' && number >= 0 && number <= 1 << 30,
            std::string(name) + "='" + value + "' must be a number");
    return static_cast<int>(number);
  }
};

struct RoomShardFlags {
  std::string shard, out;         // a task: --vote-rooms-shard i/N --vote-rooms-out FILE
  std::vector<std::string> from;  // the final job: --vote-rooms-from FILE...

  void Add(CLI::App* app) {
    app->add_option("--vote-rooms-shard",
                    shard,
                    "i/N: only generate shard i/N of the vote network's training rooms into "
                    "--vote-rooms-out, train nothing (what each task of 'train --shards' does)");
    app->add_option("--vote-rooms-out", out, "With --vote-rooms-shard: the shard database");
    app->add_option("--vote-rooms-from",
                    from,
                    "The training-room shards 0..N-1: merge them instead of generating the rooms "
                    "(the final job of 'train --shards')");
  }

  void Check(const ClusterFlags& cluster, const VoteNetFlags& vote_net) const {
    cluster.Check();
    Require(shard.empty() == out.empty(),
            "--vote-rooms-shard i/N and --vote-rooms-out go together");
    Require(shard.empty() || from.empty(),
            "--vote-rooms-shard and --vote-rooms-from do not go together");
    Require(!(cluster.Active() || !shard.empty() || !from.empty()) || vote_net.enabled,
            "--shards, --vote-rooms-shard and --vote-rooms-from split the vote network's "
            "training rooms; with --no-vote-net there are none");
    if (!cluster.Active()) return;
    Require(shard.empty() && from.empty(),
            "--shards N runs --vote-rooms-shard and --vote-rooms-from itself; give neither");
    Require(cluster.shards <= vote_net.options.rooms,
            "--shards " + std::to_string(cluster.shards) + ": more tasks than --vote-rooms " +
                std::to_string(vote_net.options.rooms));
  }
};

// Checked before anything trains (TrainVoteNet checks the merge again).
void CheckRoomShardsHoldEveryRoom(const std::vector<std::string>& shards, int rooms) {
  size_t held = 0;
  for (const std::string& shard : shards)
    held += DatasetDb(shard, DatasetDb::Mode::kReadOnly).RoomIds().size();
  Require(held == static_cast<size_t>(rooms),
          "the " + std::to_string(shards.size()) + " training-room shards hold " +
              std::to_string(held) + " of the " + std::to_string(rooms) +
              " rooms (a task's rooms are missing; rerun 'train --shards')");
}

// The trainer and scan options of the flags: --vocab and --init resolved;
// with --options, the file's, the flags given explicitly on top.
TrainingOptions ResolveTrainingFlags(const CLI::App& app,
                                     const std::string& vocab,
                                     const std::string& init,
                                     const std::string& options_file,
                                     const TrainingOptions& flags) {
  Require(vocab == "rim" || vocab == "kmeans", "--vocab '" + vocab + "' must be rim or kmeans");
  Require(init == "kmeans" || init == "pca", "--init '" + init + "' must be kmeans or pca");
  const VocabularyKind kind = vocab == "rim" ? VocabularyKind::kRim : VocabularyKind::kKMeans;
  const RimInit rim_init = init == "pca" ? RimInit::kPcaSplit : RimInit::kKMeans;
  TrainingOptions training = flags;
  if (options_file.empty()) {
    training.trainer.vocabulary.kind = kind;
    training.trainer.vocabulary.rim_init = rim_init;
    training.scan.seed = training.trainer.vocabulary.seed;
    return training;
  }
  training = TrainingOptionsFromJson(ReadFileBytes(options_file), options_file);
  VocabularyOptions& vocabulary = training.trainer.vocabulary;
  if (app.count("--vocab")) vocabulary.kind = kind;
  if (app.count("--init")) vocabulary.rim_init = rim_init;
  if (app.count("--words")) vocabulary.words = flags.trainer.vocabulary.words;
  if (app.count("--seed")) vocabulary.seed = training.scan.seed = flags.trainer.vocabulary.seed;
  if (app.count("--azimuths")) training.scan.azimuths = flags.scan.azimuths;
  return training;
}

// A task of `train --shards`: its shard of the training rooms, no training.
int GenerateRoomShard(const Catalog& catalog,
                      const VoteNetTrainingOptions& options,
                      const RoomShardFlags& room_shards) {
  const auto [shard, shards] = ParseShard(room_shards.shard);
  const int rooms =
      GenerateTrainingRoomsShard(catalog, {}, options, shard, shards, room_shards.out);
  std::printf("vote net training rooms, shard %s: %d rooms in %s\n",
              room_shards.shard.c_str(),
              rooms,
              room_shards.out.c_str());
  return 0;
}

// `train` as an array job: task i generates shard i/N of the vote
// network's training rooms into the job folder; the final job is the same
// train, which merges them and trains (scans, vocabulary, network).
ArrayJob TrainArrayJob(const ClusterFlags& cluster,
                       const VoteWorkerFlags& workers,
                       const std::string& out,
                       int argc,
                       char** argv) {
  ArrayJob job = NewArrayJob(cluster, "train");
  SetTaskOutput(&job, "rooms-", ".db");
  const std::set<std::string> drop = {
      "--vote-rooms-shard", "--vote-rooms-out", "--vote-rooms-from", "--nodes"};
  job.task_command = TaskCommandLine(argc,
                                     argv,
                                     drop,
                                     "--quiet --vote-rooms-shard " + TaskShardArgument(job) +
                                         " --vote-rooms-out " + TaskOutputArgument(job));
  std::string final_flags = "--vote-rooms-from" + AllTaskOutputs(job);
  if (workers.workers > 1) {  // the training itself as a job of N tasks
    job.final_tasks = workers.workers;
    job.final_nodes = workers.nodes;
    final_flags +=
        " --vote-slurm-group " + ShellQuote(std::filesystem::absolute(job.dir).string() + "/group");
  }
  job.final_command = TaskCommandLine(argc, argv, drop, final_flags);
  job.final_output = std::filesystem::absolute(out).string();
  return job;
}

// The vote network's options in this process (none with --no-vote-net):
// in one process without --vote-threads torch gets the CPUs the run may use
// (--threads, FURN_THREADS, the affinity mask, SLURM_CPUS_PER_TASK), as the
// pool does; with --vote-workers this process leads the workers.
std::optional<VoteNetTrainingOptions> ThisProcessVoteNetOptions(
    const VoteNetTrainingOptions* resolved,
    const VoteWorkerFlags& workers,
    bool threads_given,
    int argc,
    char** argv) {
  if (workers.workers != 1) {
    Require(resolved != nullptr, "--vote-workers trains the vote network: not with --no-vote-net");
    VoteNetTrainingOptions led = workers.Leader(*resolved, threads_given, argc, argv);
    led.Check();
    return led;
  }
  if (resolved == nullptr) return std::nullopt;
  VoteNetTrainingOptions options = *resolved;
  if (!threads_given) options.threads = ParallelThreads();
  return options;
}

// A --scorer file's bytes, checked to hold a hypothesis scorer ("" for no
// file).
std::string ReadCheckedScorer(const std::string& path) {
  if (path.empty()) return "";
  const std::string scorer = ReadFileBytes(path);
  if (!scorer.empty()) {
    Require(!HypothesisScorer::Deserialize(scorer, path).empty(),
            path + ": holds no hypothesis scorer");
  }
  return scorer;
}

}  // namespace

int RunTrain(int argc, char** argv) {
  CLI::App app{"Learn a part vocabulary and shape model from virtual scans of the catalog's models",
               "workbench train"};
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  TrainerOptions trainer;
  ScanOptions scan;
  std::string out, vocab = "rim", init = "kmeans";
  app.add_option("--out", out, "Model file (.fcm)")->required();
  app.add_option("--vocab", vocab, "rim or kmeans")->capture_default_str();
  app.add_option("--init", init, "RIM initialisation: kmeans or pca")->capture_default_str();
  app.add_option("--words", trainer.vocabulary.words, "Vocabulary size")->capture_default_str();
  app.add_option("--seed", trainer.vocabulary.seed, "Seed of clustering and scan noise")
      ->capture_default_str();
  app.add_option("--azimuths", scan.azimuths, "Views per ring")->capture_default_str();
  VoteNetFlags vote_net;
  AddVoteNetFlags(&app, &vote_net);
  std::string options_file, scorer_file;
  app.add_option("--scorer",
                 scorer_file,
                 "A hypothesis scorer to store in the model (the scorer.yml 'crossval' writes)");
  app.add_option("--options",
                 options_file,
                 "Trainer options as JSON (the \"trainer\" object of a tuned options file); the "
                 "flags above apply on top when given");
  RoomShardFlags room_shards;
  room_shards.Add(&app);
  VoteWorkerFlags workers;
  workers.Add(&app);
  ClusterFlags cluster;
  AddClusterFlags(&app, &cluster);
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);
  // A data-parallel training on Slurm without --shards: one task makes the rooms.
  if (workers.workers > 1 && cluster.shards == 0 && (cluster.slurm || cluster.emit_only))
    cluster.shards = 1;
  room_shards.Check(cluster, vote_net);
  workers.Check(cluster);
  if (cluster.Active())
    return RunArrayJob(cluster, TrainArrayJob(cluster, workers, out, argc, argv));
  const TrainingOptions training =
      ResolveTrainingFlags(app, vocab, init, options_file, {trainer, scan});
  // Every option is checked (Resolve) before the catalog opens (seconds of work).
  const VoteNetTrainingOptions* vote_net_options = vote_net.Resolve(catalog_flags.quiet);
  if (workers.IsWorker()) {
    Require(vote_net_options != nullptr, "a vote-net worker trains a vote network");
    TrainVoteNetWorker(workers.Worker(*vote_net_options, app.count("--vote-threads") > 0),
                       workers.rooms);
    return 0;
  }
  std::optional<VoteNetTrainingOptions> process_options = ThisProcessVoteNetOptions(
      vote_net_options, workers, app.count("--vote-threads") > 0, argc, argv);
  const Catalog catalog = OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags));
  for (const std::string& warning : catalog.warnings())
    std::fprintf(stderr, "warning: %s\n", warning.c_str());
  // The scorer is read before training, so a bad file costs no training time.
  const std::string scorer = ReadCheckedScorer(scorer_file);
  if (!room_shards.shard.empty()) return GenerateRoomShard(catalog, *process_options, room_shards);
  if (!room_shards.from.empty()) {  // the final job of `train --shards`
    CheckRoomShardsHoldEveryRoom(room_shards.from, process_options->rooms);
    process_options->room_shards = room_shards.from;
  }
  const TrainSummary summary = TrainFromCatalog(catalog,
                                                training.scan,
                                                training.trainer,
                                                out,
                                                {},
                                                scorer,
                                                process_options ? &*process_options : nullptr);
  PrintTrainSummary(out, training.trainer, summary);
  return 0;
}

int RunEvalParts(int argc, char** argv) {
  CLI::App app{"Protocol C: classify held-out part subsets (80/20 by view or by subset, repeated)",
               "workbench eval-parts"};
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  std::string model_path, out;
  PartEvaluationOptions options;
  app.add_option("--model", model_path, "Model file (.fcm)")->required();
  app.add_option("--out", out, "Output directory (parts.json, confusion.png)")->required();
  app.add_option("--repetitions", options.repetitions, "Random 80/20 splits")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "Seed of the splits")->capture_default_str();
  app.add_option("--azimuths", options.scan.azimuths, "Views per ring")->capture_default_str();
  app.add_option("--k", options.neighbours, "Nearest neighbours voting")->capture_default_str();
  app.add_option("--min-size", options.subsets.min_subset_size, "Smallest subset (segments)")
      ->capture_default_str();
  app.add_option("--max-subsets",
                 options.subsets.max_subsets_per_view,
                 "Most subsets per view (singletons first, then pairs, then triples)")
      ->capture_default_str();
  app.add_option("--dimensions",
                 options.index_dimensions,
                 "Principal components of the VFH the neighbour search uses (308: plain L2)")
      ->capture_default_str();
  std::string vfh_size = "model";
  app.add_option(
         "--vfh-size", vfh_size, "VFH size component: model (as the model was trained), on or off")
      ->capture_default_str();
  std::string split = "view";
  app.add_option("--split",
                 split,
                 "view: held-out views (no part of a tested subset in the library); subset: "
                 "held-out subsets, as the paper split its data")
      ->capture_default_str();
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);
  options.split = ParsePartSplit(split);
  Require(vfh_size == "model" || vfh_size == "on" || vfh_size == "off",
          "--vfh-size " + vfh_size + " must be model, on or off");
  const TrainedModel model = LoadTrainedModel(model_path);
  options.scan.seed = model.options.vocabulary.seed;
  options.subsets.vfh_size_component =
      vfh_size == "model" ? model.options.part_subsets.vfh_size_component : vfh_size == "on";
  const Catalog catalog = OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags));
  const PartEvaluation result = EvaluatePartSubsets(catalog, model, options);
  WritePartEvaluation(result, out);
  std::printf(
      "%d views, %d part subsets, %d repetitions split by %s: CAD model %.1f %% +- %.1f, category "
      "%.1f %% +- %.1f (paper, split by subset: 75.4 %%, 85.3 %%)\nwrote %s/parts.json, "
      "%s/confusion.png and confusion_models.png\n",
      result.views,
      result.subsets,
      options.repetitions,
      PartSplitName(options.split),
      100 * result.model_mean,
      100 * result.model_std,
      100 * result.category_mean,
      100 * result.category_std,
      out.c_str(),
      out.c_str());
  return 0;
}

namespace {

// `model operating-point`: per class the score of best F1, chosen on a
// dataset's frames (the full detector) or the model's own training rooms.
struct OperatingPointCommand {
  CLI::App* app = nullptr;
  std::string path, out, db_path, split = "val", rooms_path;
  EvaluateCommandOptions evaluate;
  std::optional<DetectorFlags> detector_flags;

  void Add(CLI::App* parent) {
    app = parent->add_subcommand(
        "operating-point",
        "Choose the model's operating point (per class, the score of best F1 at 20 cm) on a "
        "dataset's frames, and write the model with it");
    app->add_option("model", path, "Model file (.fcm)")->required();
    auto* db_flag = app->add_option(
        "--db", db_path, "Dataset database (generated or imported real frames): the full detector");
    auto* rooms_flag = app->add_option(
        "--training-rooms",
        rooms_path,
        "The model's own training rooms (<model>.rooms.db of 'train --keep-rooms'): the "
        "network's maxima on their validation frames, as train chooses it");
    db_flag->excludes(rooms_flag);
    rooms_flag->excludes(db_flag);
    app->add_option("--split", split, "train, val, test or all")->capture_default_str();
    app->add_option("--max-frames", evaluate.max_frames, "Frames (0: the whole split)")
        ->capture_default_str();
    app->add_option("--out", out, "Where to write the model (may be the same file)")->required();
    detector_flags.emplace(app);
  }

  int Run() {
    Require(!db_path.empty() || !rooms_path.empty(),
            "model operating-point needs --db or --training-rooms");
    evaluate.split = ParseSplit(split, "--split");
    evaluate.detector = detector_flags->Resolve();
    TrainedModel model = LoadTrainedModel(path);  // a bad model fails before detection runs
    model.operating_point = rooms_path.empty()
                                ? ChooseOperatingPointOn(model, db_path, evaluate)
                                : VoteNetOperatingPointOnRooms(model, path, rooms_path);
    SaveTrainedModel(model, out);
    std::cout << out << ": " << DescribeOperatingPoint(model.operating_point);
    return 0;
  }
};

// `model ensemble`: member 1's model with every member's vote network; all
// files are read and checked before anything is written.
struct EnsembleCommand {
  CLI::App* app = nullptr;
  std::vector<std::string> paths;
  std::string out, rooms_path;

  void Add(CLI::App* parent) {
    app = parent->add_subcommand(
        "ensemble",
        "Combine the vote networks of models trained on the same rooms with their own weights "
        "('train --vote-member K') into one model whose detection averages them");
    app->add_option("models", paths, "Model files (.fcm): member 1 first")
        ->required()
        ->expected(2, VoteNet::kMaxMembers);
    app->add_option("--out", out, "Where to write the combined model")->required();
    app->add_option("--training-rooms",
                    rooms_path,
                    "The members' training rooms: choose the ensemble's operating point on their "
                    "validation frames (else member 1's is kept)");
  }

  int Run() const {
    TrainedModel model = LoadTrainedModel(paths[0]);
    std::vector<VoteNet> members;
    for (size_t m = 0; m < paths.size(); ++m) {
      std::optional<TrainedModel> loaded;
      if (m > 0) loaded = LoadTrainedModel(paths[m]);
      const TrainedModel& member = m == 0 ? model : *loaded;
      Require(!member.vote_net.empty(), paths[m] + ": has no vote network to combine");
      const std::string input = DescribeVoteNetInput(member.vote_net_input);
      const std::string first_input = DescribeVoteNetInput(model.vote_net_input);
      Require(input == first_input,
              paths[m] + ": its vote network was trained on " + input + ", " + paths[0] + "'s on " +
                  first_input + " (members of one ensemble share their training)");
      members.push_back(VoteNet::Deserialize(member.vote_net, paths[m]));
      Require(members.back().Members() == 1,
              paths[m] + ": is an ensemble already (combine its members' own files)");
    }
    model.vote_net = VoteNet::Ensemble(std::move(members), out).Serialize();
    if (!rooms_path.empty())
      model.operating_point = VoteNetOperatingPointOnRooms(model, out, rooms_path);
    SaveTrainedModel(model, out);
    std::cout << out << ": an ensemble of " << paths.size() << " vote networks; operating point "
              << (rooms_path.empty() ? "member 1's (choose the ensemble's with --training-rooms)"
                                     : "chosen on " + rooms_path)
              << "\n";
    return 0;
  }
};

}  // namespace

int RunModel(int argc, char** argv) {
  CLI::App app{"Describe, upgrade or combine trained model files", "workbench model"};
  app.require_subcommand(1);
  std::string path, out;
  CLI::App* info = app.add_subcommand("info", "What the model file holds");
  info->add_option("model", path, "Model file (.fcm)")->required();
  CLI::App* upgrade = app.add_subcommand(
      "upgrade", "Rewrite a model file of an older format in the current one (loads faster)");
  upgrade->add_option("model", path, "Model file (.fcm) of any readable format")->required();
  upgrade->add_option("--out", out, "Where to write it (may be the same file)")->required();
  bool trust_torchscript = false;
  upgrade->add_flag("--trust-torchscript",
                    trust_torchscript,
                    "Convert a vote network stored as a TorchScript archive (model files before "
                    "issue 39) to plain tensors. Opening such an archive runs any code it holds: "
                    "only for model files you made yourself");
  OperatingPointCommand operating;
  operating.Add(&app);
  EnsembleCommand ensemble;
  ensemble.Add(&app);
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  if (ensemble.app->parsed()) return ensemble.Run();
  if (operating.app->parsed()) return operating.Run();
  if (upgrade->parsed()) {
    TrainedModel model =
        trust_torchscript ? LoadTrainedModelUnchecked(path) : LoadTrainedModel(path);
    if (!model.vote_net.empty())  // 4 and 5 gain range and levels; 2 and 3 only when trusted
      model.vote_net = trust_torchscript ? UpgradeTorchScriptVoteNet(model.vote_net, path)
                                         : VoteNet::Deserialize(model.vote_net, path).Serialize();
    SaveTrainedModel(model, out);
    std::cout << out << ": written in the current model file format\n";
    return 0;
  }
  const std::string description = DescribeTrainedModel(LoadTrainedModel(path));  // may refuse
  std::cout << path << ":\n" << description;
  return 0;
}

}  // namespace furn
