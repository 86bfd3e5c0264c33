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
#include <span>
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

nlohmann::json outcome_json(const StudyRun& run, const RunOutcome& o) {
  nlohmann::json peaks = nlohmann::json::array();
  for (const auto& p : o.peaks)
    peaks.push_back({{"node", p.node},
                     {"amplitude_m", p.amplitude_m},
                     {"omega_rad_s", p.omega_rad_s},
                     {"refined", p.refined}});
  nlohmann::json amplification = nlohmann::json::array();
  for (const auto& a : o.amplification)
    amplification.push_back(
        {{"node", a.node}, {"factor", a.factor}, {"worst_blade", a.worst_blade}});
  return {{"index", run.index},
          {"exit_code", o.exit_code},
          {"termination", o.termination},
          {"message", o.message},
          {"points", o.points},
          {"unknowns", o.unknowns},
          {"peaks", peaks},
          {"amplification", amplification},
          {"wall_s", o.wall_seconds},
          {"wrote_output", o.wrote_output}};
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

namespace {

// The keys of a scene path: `a.b[0].c` and `a.b.0.c` both give a, b, 0, c.
std::vector<std::string> path_keys(const std::string& path) {
  std::vector<std::string> keys(1);
  for (const char c : path) {
    if (c == '.' || c == '[' || c == ']') {
      if (!keys.back().empty()) keys.emplace_back();
    } else {
      keys.back() += c;
    }
  }
  if (keys.back().empty()) keys.pop_back();
  return keys;
}

bool is_index(const std::string& key) {
  return !key.empty() && key.find_first_not_of("0123456789") == std::string::npos;
}

// The unit `schema` gives `key`, or the first unit the fields of its record lists give it (a
// section written as a list, such as `excitation`); "" when it has no such key.
std::string unit_in(std::span<const frichb_param_spec> schema, const std::string& key) {
  for (const frichb_param_spec& p : schema)
    if (p.name && key == p.name) return p.unit ? p.unit : "";
  for (const frichb_param_spec& p : schema)
    if (p.fields && p.n_fields > 0) {
      std::string unit = unit_in(std::span(p.fields, p.n_fields), key);
      if (!unit.empty()) return unit;
    }
  return "";
}

// The law of the scene's contacts entry `key` (its name, or its index), or null.
const LoadedPlugin* contact_law(const Scene& scene, const std::string& key) {
  for (const ContactSpec& c : scene.contacts) {
    const bool named = c.name == key || (c.patch && c.name.starts_with(key + "."));
    const bool indexed = is_index(key) && c.entry == std::stoul(key);
    if ((named || indexed) && c.plugin) return c.plugin.get();
  }
  return nullptr;
}

}  // namespace

SweepQuantity sweep_quantity(const Scene& scene, const std::string& path) {
  std::vector<std::string> keys = path_keys(path);
  SweepQuantity q;
  if (keys.empty()) return q;
  // A number list's entry: named by its list, the unit of the list's elements.
  std::string index;
  if (keys.size() > 1 && is_index(keys.back())) {
    index = "[" + keys.back() + "]";
    keys.pop_back();
  }
  const std::string& key = keys.back();
  q.name = key + index;
  if (keys.size() == 3 && keys[0] == "structure" && keys[1] == "params") {
    if (scene.structure.plugin) q.unit = unit_in(scene.structure.plugin->schema(), key);
    return q;
  }
  if (keys.size() == 4 && keys[0] == "contacts" && keys[2] == "params") {
    if (const LoadedPlugin* law = contact_law(scene, keys[1])) q.unit = unit_in(law->schema(), key);
    return q;
  }
  // A core section: its path without list indices, contacts.<entry> as contacts[].
  std::string section;
  for (std::size_t k = 0; k + 1 < keys.size(); ++k) {
    if (k == 1 && keys[0] == "contacts") {
      section += "[]";
      continue;
    }
    if (is_index(keys[k])) continue;
    section += (section.empty() ? "" : ".") + keys[k];
  }
  for (const CoreSection& s : core_schemas())
    if (s.path == section) q.unit = unit_in(s.schema, key);
  return q;
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
    const SweepQuantity quantity = sweep_quantity(scene, sweep.path);
    sweep.name = quantity.name;
    sweep.unit = quantity.unit;
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
      sweep.log_spacing = log;
      if (log && !(from > 0 && to > 0))
        ctx.fail(entry, key + ".spacing", "log spacing needs from > 0 and to > 0");
      for (std::size_t k = 0; k < n; ++k) {
        const double s = static_cast<double>(k) / static_cast<double>(n - 1);
        // Linear: (from (n-1-k) + to k) / (n-1), exact wherever the value is an integer (a
        // seed swept from 1 to 100 in 100 values gives 1, 2, ..., 100 exactly).
        const double linear =
            (from * static_cast<double>(n - 1 - k) + to * static_cast<double>(k)) /
            static_cast<double>(n - 1);
        sweep.values.push_back(k + 1 == n ? to  // exactly the end the user wrote
                               : log      ? from * std::pow(to / from, s)
                                          : linear);
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
      YAML::Node document = reread_scene_document(scene);
      for (current = 0; current < combos[i].size(); ++current)
        set_scene_value(document, study.sweeps[current].path, combos[i][current]);
      run.scene = load_scene_variant(document, scene);
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

// Rank 0 stages the runs folder (the request's stage_runs); every rank receives it in
// `staging`. kExitOk, or the code every rank exits with when rank 0 could not stage.
int stage_runs(StudyCommunicator& comm, const StudyRequest& request, std::string& staging) {
  int staging_failure = kExitInternal;
  if (comm.rank() == 0) {
    try {
      staging = request.stage_runs().string();
    } catch (const OutputError& e) {
      spdlog::error("{}: {}", request.scene.file.string(), e.what());
      staging_failure = e.user_error() ? kExitInvalidInput : kExitOutput;
    } catch (const std::exception& e) {
      spdlog::error("{}: cannot stage the output folder: {}", request.scene.file.string(),
                    e.what());
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
                            int cores_per_run, const RunWriter& write_run, const StopToken& stop) {
  RunOptions options;
  options.stop = stop;
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

// Runs `mine` on `threads` threads (fewer when one cannot start), until done or stopped through
// the request's token. The outcomes are indexed as `runs`; rank 0 (`leader`) reports its progress.
std::vector<RunOutcome> run_share(const std::vector<StudyRun>& runs,
                                  const std::vector<std::size_t>& mine, const StudySpec& study,
                                  const std::string& staging, int threads, int cores_per_run,
                                  bool leader, const StudyRequest& request) {
  std::vector<RunOutcome> outcomes(runs.size());
  Progress progress(mine.size(), leader);  // under MPI: rank 0's share of the runs
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t k = next++; k < mine.size() && !request.stop.stop_requested(); k = next++) {
      const StudyRun& run = runs[mine[k]];
      outcomes[mine[k]] =
          run_study_member(run, study, staging, cores_per_run, request.write_run, request.stop);
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

// The gathered outcomes by run index (null where a run has none).
std::vector<nlohmann::json> outcomes_by_index(const std::vector<std::string>& gathered,
                                              std::size_t run_count) {
  std::vector<nlohmann::json> by_index(run_count);
  for (const auto& text : gathered)
    for (const auto& o : nlohmann::json::parse(text))
      by_index.at(o.at("index").get<std::size_t>()) = o;
  return by_index;
}

// A run's outcome as outcome_json wrote it.
RunOutcome outcome_from_json(const nlohmann::json& o) {
  RunOutcome outcome;
  outcome.exit_code = o.at("exit_code").get<int>();
  outcome.termination = o.at("termination").get<std::string>();
  outcome.message = o.at("message").get<std::string>();
  outcome.points = o.at("points").get<std::size_t>();
  outcome.unknowns = o.at("unknowns").get<long>();
  for (const auto& p : o.at("peaks"))
    outcome.peaks.push_back({p.at("node").get<std::string>(), p.at("amplitude_m").get<double>(),
                             p.at("omega_rad_s").get<double>(), p.at("refined").get<bool>(),
                             Eigen::VectorXd()});
  for (const auto& a : o.at("amplification"))
    outcome.amplification.push_back({a.at("node").get<std::string>(), a.at("factor").get<double>(),
                                     a.at("worst_blade").get<int>()});
  outcome.wall_seconds = o.at("wall_s").get<double>();
  outcome.wrote_output = o.at("wrote_output").get<bool>();
  return outcome;
}

}  // namespace

std::vector<AmplificationStatistics> amplification_statistics(const StudyResult& result) {
  std::vector<AmplificationStatistics> out;
  for (const auto& node : result.mistuned_nodes) {
    AmplificationStatistics s;
    s.node = node;
    s.worst_run = result.runs.size();
    std::vector<double> factors;
    for (std::size_t i = 0; i < result.runs.size(); ++i) {
      const RunOutcome& o = result.runs[i].outcome;
      if (o.exit_code != kExitOk) continue;
      for (const auto& a : o.amplification)
        if (a.node == node && a.factor > 0) {
          factors.push_back(a.factor);
          if (s.worst_run == result.runs.size() || a.factor > s.largest) {
            s.largest = a.factor;
            s.worst_run = i;
          }
        }
    }
    s.count = factors.size();
    if (!factors.empty()) {
      std::sort(factors.begin(), factors.end());
      double sum = 0;
      for (double f : factors) sum += f;
      s.mean = sum / static_cast<double>(factors.size());
      const auto percentile = [&](double q) {
        const double at = q * static_cast<double>(factors.size() - 1);
        const auto below = static_cast<std::size_t>(std::floor(at));
        const std::size_t above = std::min(below + 1, factors.size() - 1);
        return factors[below] +
               (at - static_cast<double>(below)) * (factors[above] - factors[below]);
      };
      s.p95 = percentile(0.95);
      s.p99 = percentile(0.99);
    }
    out.push_back(std::move(s));
  }
  return out;
}

StudyResult run_study(const StudyRequest& request, StudyCommunicator& comm) {
  const auto t_start = Clock::now();
  StudyResult result;
  result.leader = comm.rank() == 0;
  auto refused = [&](int code, const std::string& termination) {
    result.outcome = {code, termination, "", {}};
    return std::move(result);
  };
  if (!request.write_run || !request.stage_runs) {
    spdlog::error("run_study: the request needs stage_runs and write_run");
    return refused(kExitInternal, "internal_error");
  }
  Scene scene;
  std::unique_ptr<Registry> registry;
  StudySpec study;
  std::vector<StudyRun> runs;
  const int validation = prepare_study(request.scene, scene, registry, study, runs);
  if (const int verdict = common_verdict(comm, validation, request.scene.file); verdict != kExitOk)
    return refused(verdict, "invalid_input");
  int threads = requested_threads(request, study);

  // Rank 0 stages the runs folder; every rank writes its runs into it.
  std::string staging;
  if (const int staged = stage_runs(comm, request, staging); staged != kExitOk)
    return refused(staged, "output_error");

  const std::vector<std::size_t> mine = rank_share(comm, runs.size());
  constexpr int kMaxThreads = 256;  // a typo's 100000 threads would exhaust the process
  threads = std::clamp(std::min<int>(threads, static_cast<int>(mine.size())), 1, kMaxThreads);
  const int cores_per_run = share_cores(threads);
  if (result.leader)
    spdlog::info("study of {}: {} runs ({} on {} process(es) x {} thread(s))", scene.file.string(),
                 runs.size(), study.zip ? "zip" : "grid", comm.size(), threads);
  else
    spdlog::debug("rank {}: {} runs on {} thread(s)", comm.rank(), mine.size(), threads);

  const auto outcomes =
      run_share(runs, mine, study, staging, threads, cores_per_run, result.leader, request);
  const auto gathered = gather_outcomes(comm, runs, mine, outcomes);
  if (request.stop.stop_requested()) {
    result.outcome = {request.stop.exit_code(), "interrupted", request.stop.reason(), {}};
    return result;
  }
  result.scene_file = scene.file;
  result.scene_name = scene.name;
  result.unit = scene.continuation.unit;
  result.response = scene.output.response;
  if (scene.mistuning) result.mistuned_nodes = scene.mistuning->tuned->output.response;
  result.plots = scene.output.plots;
  result.stability = scene.output.stability;
  result.amplitude_axis = scene.output.amplitude_axis;
  result.processes = comm.size();
  result.threads = threads;
  result.study = study;
  result.optimum = runs.size();
  if (result.leader) {
    const auto by_index = outcomes_by_index(gathered, runs.size());
    result.optimum_amplitude_m = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < runs.size(); ++i) {
      StudyRunRow row{runs[i].id, runs[i].values, {}};
      if (by_index[i].is_null()) {  // a rank that ended without reporting the run
        row.outcome.termination = "internal_error";
        row.outcome.message = "no outcome was gathered for run " + runs[i].id;
      } else {
        row.outcome = outcome_from_json(by_index[i]);
      }
      if (row.outcome.exit_code != kExitOk) ++result.failed_runs;
      for (const auto& p : row.outcome.peaks)
        if (p.node == study.node && row.outcome.exit_code == kExitOk &&
            p.amplitude_m < result.optimum_amplitude_m) {
          result.optimum_amplitude_m = p.amplitude_m;
          result.optimum = i;
        }
      result.runs.push_back(std::move(row));
    }
    for (const auto& a : amplification_statistics(result))
      if (a.count > 0)
        spdlog::info(
            "amplification at {} over {} patterns: mean {:.4f}, 95th percentile {:.4f}, 99th "
            "{:.4f}, largest {:.4f} (run {})",
            a.node, a.count, a.mean, a.p95, a.p99, a.largest, result.runs[a.worst_run].id);
    if (result.failed_runs > 0)
      result.outcome = {kExitIncomplete,
                        "runs_incomplete",
                        std::to_string(result.failed_runs) + " of " + std::to_string(runs.size()) +
                            " runs did not reach the end of their sweep",
                        {}};
  }
  result.wall_seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
  return result;
}

}  // namespace frichb::core
