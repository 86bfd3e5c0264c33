#include "frichb/core/commands/study.hpp"

#include "frichb/core/numerics/dense_lu.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <mutex>
#include <numbers>
#include <set>
#include <sstream>
#include <system_error>
#include <thread>

#include "frichb/core/commands/failure.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "frichb/core/support/output.hpp"
#include "frichb/core/support/version.hpp"
#include "frichb/plugin/sdk.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using sdk::Param;

namespace {

using Clock = std::chrono::steady_clock;

// Joins text pieces into one string (no temporaries per '+').
template <class... Parts>
std::string cat(const Parts&... parts) {
  std::string out;
  (out += ... += parts);
  return out;
}

// The most runs a study may have: every run is validated, bound and kept in memory before
// any computes (and a larger count was an allocation of gigabytes, or an overflow).
constexpr std::size_t kMaxStudyRuns = 100000;

const frichb_param_spec* sweep_fields() {
  static const frichb_param_spec f[] = {
      Param::text("path",
                  "scene key to vary, e.g. contacts.shroud.params.normal_load or "
                  "excitation.0.amplitude"),
      Param::real_list("values", "", "the values (or give from, to and count)").optional(),
      Param::real("from", "", "first value of a generated range").defaults_to(0),
      Param::real("to", "", "last value of a generated range").defaults_to(0),
      Param::integer("count", "number of values of a generated range (>= 2)")
          .defaults_to(0)
          .at_least(0)
          .at_most(static_cast<double>(kMaxStudyRuns)),
      Param::text("spacing", "spacing of a generated range")
          .defaults_to_text("linear")
          .choices("linear|log"),
      Param::boolean("with_previous",
                     "vary together with the previous sweep (same number of values: the i-th "
                     "with the i-th), the pair being one axis of the grid; e.g. a gap and a "
                     "preload that go from one load case to the next")
          .defaults_to(0),
  };
  return f;
}
constexpr std::size_t kSweepFieldCount = 7;

const std::vector<frichb_param_spec>& study_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::records("sweep", "the varied keys, each with its values", sweep_fields(),
                     kSweepFieldCount),
      Param::text("combine",
                  "grid: every combination (the first sweep varies slowest); zip: the i-th "
                  "value of every sweep together (equal lengths)")
          .defaults_to_text("grid")
          .choices("grid|zip"),
      Param::text("parallel",
                  "threads per process: auto (one per core), serial, or a count; under "
                  "mpirun the runs are spread over the ranks too")
          .defaults_to_text("auto"),
      Param::text("node",
                  "node whose response curves are overlaid and whose peak is plotted against "
                  "the first swept value (default: the first of output.response)")
          .defaults_to_text(""),
  };
  return s;
}

std::string short_value(double x) {
  std::ostringstream os;
  os << std::setprecision(6) << x;
  return os.str();
}

// Every run's values (one per sweep): the grid over the axes, the first axis slowest.
std::vector<std::vector<double>> combinations(const StudySpec& study) {
  std::vector<std::vector<double>> runs;
  if (study.sweeps.empty()) return runs;
  const auto axes = study.axes();
  std::vector<std::size_t> counter(axes.size(), 0);
  while (true) {
    std::vector<double> v(study.sweeps.size());
    for (std::size_t a = 0; a < axes.size(); ++a)
      for (std::size_t k : axes[a]) v[k] = study.sweeps[k].values[counter[a]];
    runs.push_back(std::move(v));
    std::size_t a = axes.size();
    while (a > 0) {
      --a;
      if (++counter[a] < study.sweeps[axes[a].front()].values.size()) break;
      counter[a] = 0;
      if (a == 0) return runs;
    }
  }
}

int parse_threads(const std::string& text, const YAML::Node& node, const YamlContext& ctx) {
  if (text == "auto") return 0;
  if (text == "serial") return 1;
  try {
    std::size_t used = 0;
    const int n = std::stoi(text, &used);
    if (used == text.size() && n >= 1) return n;
  } catch (const std::exception&) {
  }
  ctx.fail(node, "study.parallel",
           "expected auto, serial or a thread count >= 1, got '" + text + "'");
}

// The CSV cell of a number (empty when not finite: a failed run has no peak).
std::string cell(double x) {
  if (!std::isfinite(x)) return "";
  std::ostringstream os;
  os << std::setprecision(12) << x;
  return os.str();
}

std::string csv_text(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return q + "\"";
}

nlohmann::json outcome_json(const StudyRun& run, const RunOutcome& o) {
  nlohmann::json peaks = nlohmann::json::array();
  for (const auto& p : o.peaks)
    peaks.push_back({{"node", p.node},
                     {"amplitude_m", p.amplitude_m},
                     {"omega_rad_s", p.omega_rad_s},
                     {"refined", p.refined}});
  return {{"index", run.index},           {"exit_code", o.exit_code},
          {"termination", o.termination}, {"message", o.message},
          {"points", o.points},           {"peaks", peaks},
          {"wall_s", o.wall_seconds},     {"wrote_output", o.wrote_output}};
}

// Reports finished runs: a bar on a terminal, a log line per run otherwise.
class Progress {
 public:
  Progress(std::size_t total, bool enabled) : total_(total), enabled_(enabled) {
    bar_ = enabled_ && isatty(fileno(stderr)) && spdlog::should_log(spdlog::level::info);
  }
  void finished(const std::string& line) {
    if (!enabled_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    ++done_;
    const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
    const double eta = elapsed / static_cast<double>(done_) * static_cast<double>(total_ - done_);
    if (!bar_) {
      spdlog::info("[{}/{}] {}", done_, total_, line);
      return;
    }
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(kWidth * done_ / std::max<std::size_t>(total_, 1));
    std::fprintf(stderr, "\r[%s%s] %zu/%zu runs  %.0f s elapsed, about %.0f s left   ",
                 std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 std::string(static_cast<std::size_t>(kWidth - filled), ' ').c_str(), done_, total_,
                 elapsed, eta);
    if (done_ == total_) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  }

 private:
  std::size_t total_, done_ = 0;
  bool enabled_, bar_ = false;
  std::mutex mutex_;
  Clock::time_point start_ = Clock::now();
};

}  // namespace

std::vector<std::vector<std::size_t>> StudySpec::axes() const {
  std::vector<std::vector<std::size_t>> out;
  for (std::size_t k = 0; k < sweeps.size(); ++k) {
    if (out.empty() || !(zip || sweeps[k].with_previous)) out.emplace_back();
    out.back().push_back(k);
  }
  return out;
}

StudySpec load_study(const Scene& scene) {
  YamlContext ctx{scene.file.string()};
  YAML::Node root = scene.root;
  YAML::Node sn = root["study"];
  if (!sn) ctx.fail(root, "study", "the scene has no study: section");
  const auto values = validate_params(sn, study_schema(), "study", ctx);
  const sdk::Params v(study_schema().data(), study_schema().size(), values.data());
  StudySpec study;
  study.zip = v.text("combine") == "zip";
  study.threads = parse_threads(v.text("parallel"), sn["parallel"] ? sn["parallel"] : sn, ctx);
  study.node = v.text("node");
  if (study.node.empty()) {
    study.node = scene.output.response.empty() ? "" : scene.output.response.front();
  } else if (std::find(scene.output.response.begin(), scene.output.response.end(), study.node) ==
             scene.output.response.end()) {
    ctx.fail(sn["node"], "study.node", "'" + study.node + "' is not among output.response");
  }
  const std::size_t count = v.record_count("sweep");
  if (count == 0) ctx.fail(sn, "study.sweep", "give at least one swept key");
  std::set<std::string> seen;
  for (std::size_t i = 0; i < count; ++i) {
    const auto r = v.record("sweep", i);
    const std::string key = "study.sweep[" + std::to_string(i) + "]";
    YAML::Node entry = sn["sweep"][i];
    SweepSpec sweep;
    sweep.path = r.text("path");
    sweep.with_previous = r.boolean("with_previous");
    if (sweep.with_previous && i == 0)
      ctx.fail(entry["with_previous"], key + ".with_previous",
               "the first sweep has no previous sweep to vary with");
    if (!seen.insert(sweep.path).second)
      ctx.fail(entry["path"], key + ".path", "'" + sweep.path + "' is swept twice");
    try {
      check_scene_path(root, sweep.path);
    } catch (const std::invalid_argument& e) {
      ctx.fail(entry["path"], key + ".path", e.what());
    }
    const bool listed = r.present("values");
    const bool ranged = r.present("from") || r.present("to") || r.present("count");
    if (listed == ranged) ctx.fail(entry, key, "give either values: [...] or from, to and count");
    if (listed) {
      sweep.values = r.reals("values");
      if (sweep.values.empty()) ctx.fail(entry["values"], key + ".values", "no values");
    } else {
      if (!(r.present("from") && r.present("to") && r.present("count")))
        ctx.fail(entry, key, "a generated range needs from, to and count");
      const double from = r.real("from"), to = r.real("to");
      const auto n = static_cast<std::size_t>(r.integer("count"));
      if (n < 2) ctx.fail(entry["count"], key + ".count", "count >= 2");
      const bool log = r.text("spacing") == "log";
      if (log && !(from > 0 && to > 0))
        ctx.fail(entry, key + ".spacing", "log spacing needs from > 0 and to > 0");
      for (std::size_t k = 0; k < n; ++k) {
        const double s = static_cast<double>(k) / static_cast<double>(n - 1);
        sweep.values.push_back(k + 1 == n ? to  // exactly the end the user wrote
                               : log      ? from * std::pow(to / from, s)
                                          : from + (to - from) * s);
      }
    }
    study.sweeps.push_back(std::move(sweep));
  }
  // Sweeps varying together have equal lengths; the grid's size is the product over axes.
  std::size_t total = 1;  // saturates
  for (const auto& axis : study.axes()) {
    const auto& first = study.sweeps[axis.front()];
    for (std::size_t k : axis)
      if (study.sweeps[k].values.size() != first.values.size())
        ctx.fail(sn["sweep"][k], "study.sweep[" + std::to_string(k) + "]",
                 std::string(study.zip ? "combine: zip" : "with_previous") +
                     " needs sweeps of equal lengths (" + std::to_string(first.values.size()) +
                     " and " + std::to_string(study.sweeps[k].values.size()) + " values)");
    total = total > kMaxStudyRuns / first.values.size() ? kMaxStudyRuns + 1
                                                        : total * first.values.size();
  }
  if (total > kMaxStudyRuns)
    ctx.fail(sn["sweep"], "study.sweep",
             "more than " + std::to_string(kMaxStudyRuns) + " runs (the most a study may have)");
  return study;
}

std::vector<StudyRun> prepare_study_runs(const Scene& scene, const StudySpec& study,
                                         const Registry& registry) {
  std::vector<StudyRun> runs;
  const auto combos = combinations(study);
  const YamlContext ctx{scene.file.string()};
  YAML::Node root = scene.root;
  const int width = std::max<int>(4, static_cast<int>(std::to_string(combos.size()).size()));
  for (std::size_t i = 0; i < combos.size(); ++i) {
    StudyRun run;
    run.index = i;
    std::ostringstream id;
    id << std::setw(width) << std::setfill('0') << i;
    run.id = id.str();
    run.values = combos[i];
    std::string label;
    for (std::size_t k = 0; k < combos[i].size(); ++k)
      label += (k ? ", " : "") + study.sweeps[k].path + " = " + short_value(combos[i][k]);
    std::size_t current = 0;  // the sweep whose value is being applied (for errors)
    try {
      YAML::Node document = load_scene_document(scene.file, scene.overrides);
      for (current = 0; current < combos[i].size(); ++current)
        set_scene_value(document, study.sweeps[current].path, combos[i][current]);
      run.scene = load_scene(document, scene.file);
      run.scene.overrides = scene.overrides;
      run.scene.allow_scene_plugins = scene.allow_scene_plugins;
      bind_plugins(run.scene, registry);
      for (const auto& c : run.scene.contacts) ContactLawInstance probe(c.plugin, c.values);
    } catch (const SceneError& e) {
      // An error about a swept key is the sweep's: point at it (the scene's line is where the
      // key was written, not where the bad value came from).
      const std::string& kp = e.key_path();
      std::size_t k = study.sweeps.size();
      for (std::size_t s = 0; s < study.sweeps.size(); ++s) {
        const std::string& p = study.sweeps[s].path;
        const std::string last = p.substr(p.find_last_of(".]") + 1);
        if (!last.empty() && kp.size() >= last.size() &&
            kp.compare(kp.size() - last.size(), last.size(), last) == 0)
          k = s;
      }
      const std::string why = cat(kp, ": ", e.message(), " (study run ", run.id, ": ", label, ")");
      if (k == study.sweeps.size()) {
        if (e.line() > 0)
          throw SceneError(ctx.file, e.line(), e.column(), kp,
                           e.message() + " (study run " + run.id + ": " + label + ")");
        ctx.fail(root["study"], "study", why);
      }
      ctx.fail(root["study"]["sweep"][k], "study.sweep[" + std::to_string(k) + "]", why);
    } catch (const std::exception& e) {
      const std::size_t k = std::min(current, study.sweeps.size() - 1);
      ctx.fail(root["study"]["sweep"][k], "study.sweep[" + std::to_string(k) + "]",
               std::string("run ") + run.id + " (" + label + "): " + e.what());
    }
    runs.push_back(std::move(run));
  }
  return runs;
}

std::vector<CoreSection> study_schemas() {
  return {
      {"study", study_schema(),
       "Optional; used by `frichb study` (and ignored by `frichb run`). Each sweep varies "
       "one numeric scalar of the scene, addressed by its path: map keys separated by `.`, "
       "list entries by their index (`excitation.0.amplitude`; `[0]` also works but must be quoted "
       "in YAML's flow style), a contact by its name (`contacts.shroud.params.mu`). "
       "The last key may be absent from the scene (its default is then overridden)."},
      {"study.sweep[]",
       std::vector<frichb_param_spec>(sweep_fields(), sweep_fields() + kSweepFieldCount),
       "Give `values`, or `from`, `to` and `count` (with `spacing`)."}};
}

namespace {

// The scene, its study and every run, validated and bound on this rank: an ExitCode.
int prepare_study(const SceneInput& input, Scene& scene, std::unique_ptr<Registry>& registry,
                  StudySpec& study, std::vector<StudyRun>& runs) {
  const fs::path& scene_file = input.file;
  try {
    BoundScene bound = load_bound_scene(input);
    scene = std::move(bound.scene);
    registry = std::move(bound.registry);
  } catch (...) {
    return report_failure(scene_file.string());
  }
  try {
    study = load_study(scene);
    runs = prepare_study_runs(scene, study, *registry);
  } catch (const SceneError& e) {
    spdlog::error("{}", e.what());
    return kExitInvalidInput;
  } catch (const std::exception& e) {
    spdlog::error("{}: {}", scene_file.string(), e.what());
    return kExitInvalidInput;
  }
  return kExitOk;
}

// Every rank takes part in the verdict, so that a rank failing validation alone (another
// plugin folder on its node, say) stops them all instead of leaving them waiting. kExitOk when
// every rank validated, else the code of a rank that did not.
int common_verdict(StudyCommunicator& comm, int validation, const fs::path& scene_file) {
  std::string verdict = std::to_string(validation);
  for (const auto& status : comm.gather(verdict))
    if (status != std::to_string(kExitOk)) verdict = status;
  verdict = comm.broadcast(verdict);
  if (verdict != std::to_string(kExitOk) && validation == kExitOk)
    spdlog::error("rank {}: another rank could not validate {}: stopping", comm.rank(),
                  scene_file.string());
  return std::stoi(verdict);
}

// Threads per process: the request's, else the study's; auto is one per core, shared among
// the ranks Open MPI starts on the same node.
int requested_threads(const StudyRequest& request, const StudySpec& study) {
  int threads = request.threads >= 0 ? request.threads : study.threads;
  if (threads <= 0) {
    threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    if (const char* local = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE"))
      threads = std::max(1, threads / std::max(1, std::atoi(local)));
  }
  return threads;
}

// Rank 0 stages the output (into `out`); every rank receives the staging folder of the runs
// in `staging`. kExitOk, or the code every rank exits with when rank 0 could not stage.
int stage_output(StudyCommunicator& comm, const fs::path& out_dir, const fs::path& scene_file,
                 std::unique_ptr<StagedOutput>& out, std::string& staging) {
  int staging_failure = kExitInternal;
  if (comm.rank() == 0) {
    try {
      out = std::make_unique<StagedOutput>(
          out_dir, std::vector<std::string>{"study.csv", "study.json", "overlay.gp", "overlay.png",
                                            "peak.gp", "peak.png", "runs"});
      staging = out->path("runs").string();
    } catch (const OutputError& e) {
      spdlog::error("{}: {}", scene_file.string(), e.what());
      staging_failure = e.user_error() ? kExitInvalidInput : kExitOutput;
    } catch (const std::exception& e) {
      spdlog::error("cannot create the output folder {}: {}", out_dir.string(), e.what());
    }
  }
  staging = comm.broadcast(staging.empty() ? "!" + std::to_string(staging_failure) : staging);
  if (staging.starts_with("!")) return std::stoi(staging.substr(1));
  return kExitOk;
}

// This rank's runs: run i on rank i mod size.
std::vector<std::size_t> rank_share(const StudyCommunicator& comm, std::size_t run_count) {
  std::vector<std::size_t> mine;
  for (std::size_t i = static_cast<std::size_t>(comm.rank()); i < run_count;
       i += static_cast<std::size_t>(comm.size()))
    mine.push_back(i);
  return mine;
}

// Each run factorises (OpenBLAS) and traces its contacts on the cores its process and
// threads leave, so that the study's threads and ranks do not oversubscribe the cores. Sets
// the dense solver's threads and returns the cores of one run.
int share_cores(int threads) {
  int local_ranks = 1;
  if (const char* local = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE"))
    local_ranks = std::max(1, std::atoi(local));
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int cores_per_run = std::max(1, cores / (local_ranks * threads));
  set_dense_solver_threads(cores_per_run);
  return cores_per_run;
}

// One run of the study, quiet and without plots, into its folder under `staging`.
RunOutcome run_study_member(const StudyRun& run, const StudySpec& study, const std::string& staging,
                            int cores_per_run, const RunWriter& write_run) {
  RunOptions options;
  options.quiet = true;
  options.plots = 0;
  options.contact_threads = cores_per_run;
  nlohmann::json params = nlohmann::json::object();
  for (std::size_t s = 0; s < study.sweeps.size(); ++s)
    params[study.sweeps[s].path] = run.values[s];
  options.study_context = {{"run", run.id}, {"parameters", params}};
  return run_member(run.scene, fs::path(staging) / run.id, options, write_run);
}

// The progress line of a finished run: its values, termination, peak of study.node and time.
std::string progress_line(const StudyRun& run, const RunOutcome& o, const StudySpec& study) {
  std::string line = "run " + run.id + " (";
  for (std::size_t s = 0; s < study.sweeps.size(); ++s)
    line += (s ? ", " : "") + study.sweeps[s].path + " = " + short_value(run.values[s]);
  line += "): " + o.termination;
  for (const auto& p : o.peaks)
    if (p.node == study.node)
      line += ", peak " + short_value(p.amplitude_m) + " m at " +
              short_value(p.omega_rad_s / run.scene.continuation.to_rad_per_s()) + " " +
              unit_name(run.scene.continuation.unit);
  line += " (" + short_value(o.wall_seconds) + " s)";
  return line;
}

// Runs `mine` on `threads` threads (fewer when one cannot start), until done or interrupted.
// The outcomes are indexed as `runs`; rank 0 (`leader`) reports its progress.
std::vector<RunOutcome> run_share(const std::vector<StudyRun>& runs,
                                  const std::vector<std::size_t>& mine, const StudySpec& study,
                                  const std::string& staging, int threads, int cores_per_run,
                                  bool leader, const RunWriter& write_run) {
  std::vector<RunOutcome> outcomes(runs.size());
  Progress progress(mine.size(), leader);  // under MPI: rank 0's share of the runs
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t k = next++; k < mine.size() && !interrupted(); k = next++) {
      const StudyRun& run = runs[mine[k]];
      outcomes[mine[k]] = run_study_member(run, study, staging, cores_per_run, write_run);
      progress.finished(progress_line(run, outcomes[mine[k]], study));
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) {
    try {
      pool.emplace_back(worker);
    } catch (const std::system_error& e) {
      spdlog::warn("could not start thread {} of {} ({}): going on with {}", t + 1, threads,
                   e.what(), t);
      break;
    }
  }
  worker();
  for (auto& t : pool) t.join();
  return outcomes;
}

// Rank 0 receives every rank's outcomes (JSON text per rank, as outcome_json writes them).
std::vector<std::string> gather_outcomes(StudyCommunicator& comm, const std::vector<StudyRun>& runs,
                                         const std::vector<std::size_t>& mine,
                                         const std::vector<RunOutcome>& outcomes) {
  nlohmann::json my_outcomes = nlohmann::json::array();
  for (std::size_t i : mine) my_outcomes.push_back(outcome_json(runs[i], outcomes[i]));
  // Messages may quote file names that are not UTF-8: replaced, not thrown on.
  return comm.gather(my_outcomes.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

// What rank 0 writes the study's outputs from.
struct StudyReport {
  const Scene& scene;
  const StudySpec& study;
  const std::vector<StudyRun>& runs;
  int processes = 1;
  int threads = 1;                       // per process
  std::vector<nlohmann::json> outcomes;  // every run's outcome_json, by run index
};

// The gathered outcomes by run index (null where a run has none).
std::vector<nlohmann::json> outcomes_by_index(const std::vector<std::string>& gathered,
                                              std::size_t run_count) {
  std::vector<nlohmann::json> by_index(run_count);
  for (const auto& text : gathered)
    for (const auto& o : nlohmann::json::parse(text))
      by_index.at(o.at("index").get<std::size_t>()) = o;
  return by_index;
}

// study.csv's text and study.json's runs, with the count of failed runs and the run of the
// lowest peak of study.node among those that reached the end of their sweep.
struct StudyIndex {
  std::string csv;
  nlohmann::json runs = nlohmann::json::array();
  int failed = 0;
  std::size_t best = 0;  // the runs' count when no run qualifies
  double best_amp = std::numeric_limits<double>::infinity();
};

StudyIndex study_index(const StudyReport& r) {
  const Scene& scene = r.scene;
  const StudySpec& study = r.study;
  const auto& runs = r.runs;
  const auto& C = scene.continuation;
  const double unit = C.to_rad_per_s();
  const std::string fcol = C.unit == FrequencyUnit::kHz ? "hz" : "rad_s";
  // study.csv: one row per run.
  std::ostringstream csv;
  csv << "run";
  for (const auto& s : study.sweeps) csv << "," << csv_text(s.path);
  csv << ",exit_code,termination,points";
  for (const auto& node : scene.output.response)
    csv << "," << node << "_peak_amplitude_m," << node << "_peak_frequency_" << fcol;
  csv << ",wall_s\n";
  StudyIndex index;
  index.best = runs.size();
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const nlohmann::json& o = r.outcomes[i];
    if (o.is_null()) throw std::runtime_error("no outcome for run " + runs[i].id);
    csv << runs[i].id;
    for (double x : runs[i].values) csv << "," << cell(x);
    csv << "," << o["exit_code"].get<int>() << "," << o["termination"].get<std::string>() << ","
        << o["points"].get<std::size_t>();
    nlohmann::json peaks = nlohmann::json::object();
    for (const auto& node : scene.output.response) {
      double amp = std::numeric_limits<double>::quiet_NaN(), w = amp;
      for (const auto& p : o["peaks"])
        if (p["node"] == node) {
          amp = p["amplitude_m"].get<double>();
          w = p["omega_rad_s"].get<double>();
        }
      csv << "," << cell(amp) << "," << cell(w / unit);
      if (std::isfinite(amp))
        peaks[node] = {{"amplitude_m", amp}, {"frequency", w / unit}, {"omega_rad_s", w}};
      if (node == study.node && o["exit_code"] == kExitOk && amp < index.best_amp) {
        index.best_amp = amp;
        index.best = i;
      }
    }
    csv << "," << cell(o["wall_s"].get<double>()) << "\n";
    if (o["exit_code"].get<int>() != kExitOk) ++index.failed;
    nlohmann::json params = nlohmann::json::object();
    for (std::size_t s = 0; s < study.sweeps.size(); ++s)
      params[study.sweeps[s].path] = runs[i].values[s];
    index.runs.push_back({{"run", runs[i].id},
                          {"folder", o["wrote_output"].get<bool>() ? "runs/" + runs[i].id : ""},
                          {"parameters", params},
                          {"exit_code", o["exit_code"]},
                          {"termination", o["termination"]},
                          {"message", o["message"]},
                          {"points", o["points"]},
                          {"peak", peaks},
                          {"wall_s", o["wall_s"]}});
  }
  index.csv = csv.str();
  return index;
}

// study.json: the study's settings, every run's index entry and the optimum.
nlohmann::json study_json(const StudyReport& r, const StudyIndex& index, double wall) {
  const StudySpec& study = r.study;
  nlohmann::json sweeps = nlohmann::json::array();
  for (const auto& s : study.sweeps) sweeps.push_back({{"path", s.path}, {"values", s.values}});
  nlohmann::json optimum = nullptr;
  if (index.best < r.runs.size())
    optimum = {{"run", r.runs[index.best].id},
               {"node", study.node},
               {"parameters", index.runs[index.best]["parameters"]},
               {"peak_amplitude_m", index.best_amp},
               {"among", "runs that reached the end of their sweep"}};
  return {{"frichb_version", version()},
          {"scene", {{"file", r.scene.file.string()}, {"name", r.scene.name}}},
          {"sweeps", sweeps},
          {"combine", study.zip ? "zip" : "grid"},
          {"processes", r.processes},
          {"threads_per_process", r.threads},
          {"node", study.node},
          {"frequency_unit", unit_name(r.scene.continuation.unit)},
          {"runs", index.runs},
          {"failed_runs", index.failed},
          {"optimum", optimum},
          {"wall_s", wall}};
}

// overlay.gp/png: the response curves of study.node, one line per run that wrote its output
// (nothing when none did).
void write_overlay_plot(const StudyReport& r, const std::string& title, const StagedOutput& out) {
  const StudySpec& study = r.study;
  const auto& runs = r.runs;
  const auto& C = r.scene.continuation;
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb study; `gnuplot overlay.gp` remakes it\n"
     << "set terminal pngcairo size 1100,700 noenhanced\nset output 'overlay.png'\n"
     << "set datafile separator ','\nset grid\nset key outside right top\n"
     << "set title " << gnuplot_string(title + ": " + study.node + " over the study") << "\n"
     << "set xlabel 'frequency [" << unit_name(C.unit) << "]'\n"
     << "set ylabel 'amplitude [m]'\n"
     << "set palette defined (0 '#1f4fbf', 0.5 '#2ca02c', 1 '#d62728')\nunset colorbox\n"
     << "plot ";
  bool first = true;
  const int xcol = C.unit == FrequencyUnit::kHz ? 2 : 3;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (!r.outcomes[i]["wrote_output"].get<bool>()) continue;
    std::string label;
    for (std::size_t s = 0; s < study.sweeps.size(); ++s)
      label += (s ? ", " : "") +
               study.sweeps[s].path.substr(study.sweeps[s].path.find_last_of('.') + 1) + "=" +
               short_value(runs[i].values[s]);
    gp << (first ? "" : ", \\\n     ") << gnuplot_string("runs/" + runs[i].id + "/response.csv")
       << " using " << xcol << ":(column(" << gnuplot_string(study.node + "_amplitude_m")
       << ")) with lines lw 1.5 lc palette frac "
       << (runs.size() > 1 ? static_cast<double>(i) / static_cast<double>(runs.size() - 1) : 0.0)
       << " title " << gnuplot_string(label);
    first = false;
  }
  gp << "\n";
  if (!first) {
    write_text(out.path("overlay.gp"), gp.str());
    run_gnuplot(out.path("overlay.gp"));
  }
}

// The plot command of peak.gp when the grid has more than one axis: the first axis on x, one
// line per combination of the sweeps of the other axes.
std::string peak_plot_per_combination(const StudyReport& r, std::size_t first_axis, int peak_col) {
  const StudySpec& study = r.study;
  std::vector<std::vector<double>> others;
  for (const auto& run : r.runs) {
    std::vector<double> rest(run.values.begin() + static_cast<std::ptrdiff_t>(first_axis),
                             run.values.end());
    if (std::find(others.begin(), others.end(), rest) == others.end()) others.push_back(rest);
  }
  std::ostringstream pk;
  pk << "plot ";
  for (std::size_t g = 0; g < others.size(); ++g) {
    std::string cond = "1", label;
    for (std::size_t s = first_axis; s < study.sweeps.size(); ++s) {
      const double value = others[g][s - first_axis];
      cond += " && abs(column(" + std::to_string(s + 2) + ") - (" + format_scene_value(value) +
              ")) <= 1e-9 * (1 + abs(" + format_scene_value(value) + "))";
      label += (s > first_axis ? ", " : "") +
               study.sweeps[s].path.substr(study.sweeps[s].path.find_last_of('.') + 1) + "=" +
               short_value(value);
    }
    pk << (g ? ", \\\n     " : "") << "'study.csv' using 2:((" << cond << ") ? column(" << peak_col
       << ") : 1/0) with linespoints pt 7 lw 2 title " << gnuplot_string(label);
  }
  pk << "\n";
  return pk.str();
}

// peak.gp/png: the peak amplitude of study.node (from study.csv) against the first swept value.
void write_peak_plot(const StudyReport& r, const std::string& title, const StagedOutput& out) {
  const StudySpec& study = r.study;
  const auto& response = r.scene.output.response;
  const auto& s0 = study.sweeps.front();
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (double x : s0.values) {
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  std::ostringstream pk;
  pk << "# gnuplot script written by frichb study; `gnuplot peak.gp` remakes it\n"
     << "set terminal pngcairo size 900,600 noenhanced\nset output 'peak.png'\n"
     << "set datafile separator ','\nset grid\nset key outside right top\n"
     << "set title " << gnuplot_string(title + ": peak amplitude of " + study.node) << "\n"
     << "set xlabel " << gnuplot_string(s0.path) << "\nset ylabel 'peak amplitude [m]'\n"
     << (lo > 0 && hi / lo > 100 ? "set logscale x\n" : "");
  const int peak_col =
      static_cast<int>(1 + study.sweeps.size() + 3) +
      2 * static_cast<int>(std::find(response.begin(), response.end(), study.node) -
                           response.begin()) +
      1;
  const std::size_t first_axis = study.axes().front().size();
  if (first_axis == study.sweeps.size()) {
    pk << "plot 'study.csv' using 2:" << peak_col << " with linespoints pt 7 lw 2 title "
       << gnuplot_string(study.node) << "\n";
  } else {
    pk << peak_plot_per_combination(r, first_axis, peak_col);
  }
  write_text(out.path("peak.gp"), pk.str());
  run_gnuplot(out.path("peak.gp"));
}

// Rank 0 writes the study's index and plots from the gathered outcomes into `out` and commits
// it to `out_dir` (`out` removed, staging and all, when that fails). Returns an ExitCode.
int write_study(StudyReport report, const std::vector<std::string>& gathered,
                const StudyRequest& request, const fs::path& out_dir,
                std::unique_ptr<StagedOutput>& out, Clock::time_point t_start) {
  const Scene& scene = report.scene;
  const StudySpec& study = report.study;
  const auto& runs = report.runs;
  int code = kExitOk;
  try {
    report.outcomes = outcomes_by_index(gathered, runs.size());
    const StudyIndex index = study_index(report);
    write_text(out->path("study.csv"), index.csv);
    const double wall = std::chrono::duration<double>(Clock::now() - t_start).count();
    write_json(out->path("study.json"), study_json(report, index, wall));
    if (scene.output.plots && !study.node.empty()) {
      const std::string title = scene.name.empty() ? scene.file.stem().string() : scene.name;
      write_overlay_plot(report, title, *out);
      write_peak_plot(report, title, *out);
    }
    if (interrupted())  // a signal while gnuplot ran: nothing is committed
      throw std::runtime_error("interrupted by signal " + std::to_string(interrupt_signal()) +
                               "; no output written");
    out->commit();
    spdlog::info("wrote {}: {} runs, {} did not reach the end of their sweep{} ({:.2f} s)",
                 out_dir.string(), runs.size(), index.failed,
                 index.best < runs.size()
                     ? "; lowest peak of " + study.node + " among them: run " +
                           runs[index.best].id + " (" + short_value(index.best_amp) + " m)"
                     : std::string(),
                 wall);
    code = index.failed ? kExitIncomplete : kExitOk;
  } catch (const OutputError& e) {
    spdlog::error("{}: writing the study: {}", request.scene.file.string(), e.what());
    code = e.user_error() ? kExitInvalidInput : kExitOutput;
  } catch (const std::exception& e) {
    spdlog::error("{}: writing the study index: {}", request.scene.file.string(), e.what());
    code = interrupted() ? interrupted_exit_code() : kExitInternal;
  }
  if (code != kExitOk && code != kExitIncomplete) out.reset();  // staging removed
  return code;
}

}  // namespace

int run_study(const StudyRequest& request, StudyCommunicator& comm) {
  if (!request.write_run) {
    spdlog::error("run_study: the request has no RunWriter (write_run) for its runs");
    return kExitInternal;
  }
  const auto t_start = Clock::now();
  const bool leader = comm.rank() == 0;
  Scene scene;
  std::unique_ptr<Registry> registry;
  StudySpec study;
  std::vector<StudyRun> runs;
  const int validation = prepare_study(request.scene, scene, registry, study, runs);
  if (const int verdict = common_verdict(comm, validation, request.scene.file); verdict != kExitOk)
    return verdict;
  int threads = requested_threads(request, study);
  fs::path out_dir = request.output_directory;
  if (out_dir.empty()) out_dir = fs::path("out") / (scene.file.stem().string() + "-study");

  // Rank 0 stages the output; every rank writes its runs into the staging folder.
  std::unique_ptr<StagedOutput> out;
  std::string staging;
  if (const int staged = stage_output(comm, out_dir, request.scene.file, out, staging);
      staged != kExitOk)
    return staged;

  const std::vector<std::size_t> mine = rank_share(comm, runs.size());
  constexpr int kMaxThreads = 256;  // a typo's 100000 threads would exhaust the process
  threads = std::clamp(std::min<int>(threads, static_cast<int>(mine.size())), 1, kMaxThreads);
  const int cores_per_run = share_cores(threads);
  if (leader)
    spdlog::info("study of {}: {} runs ({} on {} process(es) x {} thread(s)) -> {}",
                 scene.file.string(), runs.size(), study.zip ? "zip" : "grid", comm.size(), threads,
                 out_dir.string());
  else
    spdlog::debug("rank {}: {} runs on {} thread(s)", comm.rank(), mine.size(), threads);

  const auto outcomes =
      run_share(runs, mine, study, staging, threads, cores_per_run, leader, request.write_run);
  const auto gathered = gather_outcomes(comm, runs, mine, outcomes);
  int code = kExitOk;
  if (leader && interrupted()) {
    spdlog::error("{}: interrupted by signal {}; no output written", request.scene.file.string(),
                  interrupt_signal());
    code = interrupted_exit_code();
  } else if (leader) {
    code = write_study({scene, study, runs, comm.size(), threads, {}}, gathered, request, out_dir,
                       out, t_start);
  }
  return std::stoi(comm.broadcast(std::to_string(code)));
}

}  // namespace frichb::core
