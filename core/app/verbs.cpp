// The verbs of frichb: what each takes, its help, and the call into the core (cli.hpp).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <optional>
#include <sstream>
#include <utility>

#include "cli.hpp"
#include "frichb/core/commands/catalog.hpp"
#include "frichb/core/commands/convergence.hpp"
#include "frichb/core/commands/failure.hpp"
#include "frichb/core/commands/import.hpp"
#include "frichb/core/commands/loop.hpp"
#include "frichb/core/commands/modes.hpp"
#include "frichb/core/commands/nma.hpp"
#include "frichb/core/commands/peaks.hpp"
#include "frichb/core/commands/run.hpp"
#include "frichb/core/commands/study.hpp"
#include "frichb/core/commands/timesim.hpp"
#include "frichb/core/commands/validate.hpp"
#include "frichb/core/report/catalog_report.hpp"
#include "frichb/core/report/convergence_report.hpp"
#include "frichb/core/report/import_report.hpp"
#include "frichb/core/report/loop_report.hpp"
#include "frichb/core/report/modes_report.hpp"
#include "frichb/core/report/nma_report.hpp"
#include "frichb/core/report/peaks_report.hpp"
#include "frichb/core/report/run_report.hpp"
#include "frichb/core/report/study_report.hpp"
#include "frichb/core/report/timesim_report.hpp"
#include "frichb/core/report/validate_report.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "frichb/core/support/output.hpp"
#include "mpi_communicator.hpp"

namespace frichb::app {
namespace {

namespace fs = std::filesystem;
using core::kExitUsage;

// The one way a verb runs on the command line (core/include/frichb/core/commands/verb.hpp):
// `compute` returns the verb's result; unless a stop (SIGINT, SIGTERM) ended it, `write` turns it
// into the verb's files (or its printout); the outcome's status is the exit code. Whatever either
// throws is mapped by report_failure, naming `subject` (the input file, or the output folder of
// a verb without one). The verb logs how its computation ended.
template <typename Compute, typename Write>
int conclude(const std::string& subject, const Compute& compute, const Write& write) {
  try {
    const auto result = compute();
    if (result.outcome.status >= 128) {  // stopped: nothing is written
      spdlog::error("{}: {}; no output written", subject, result.outcome.message);
      return result.outcome.status;
    }
    write(result);
    return result.outcome.status;
  } catch (...) {
    return core::report_failure(subject);
  }
}

// `conclude` for a verb that writes an output folder. The folder is staged before any work
// (core::StagedOutput: a place that cannot hold the results, or a folder another run writes,
// stops the verb at once; what is staged, and any folder made on the way, is removed again
// when nothing is committed); `compute` receives it (a verb whose members are written as they
// end writes them into it); the result is written into it and committed whole, unless the
// call's token was stopped.
template <typename Compute, typename Write>
int conclude_into(const Invocation& call, const std::string& subject, const fs::path& folder,
                  const std::vector<std::string>& managed, const Compute& compute,
                  const Write& write) {
  std::optional<core::StagedOutput> out;
  try {
    out.emplace(folder, managed, core::StagingControl(call.stop.token()));
  } catch (const core::OutputError& e) {
    spdlog::error("{}", e.what());
    return e.user_error() ? core::kExitInvalidInput : core::kExitOutput;
  }
  return conclude(
      subject, [&] { return compute(*out); },
      [&](const auto& result) {
        write(result, *out);
        out->commit();
        spdlog::info("wrote {}", folder.string());
      });
}

// A comma-separated list of integers from 1 to 100000 (convergence settings).
bool parse_counts(const std::string& text, std::vector<int>& counts) {
  counts.clear();
  std::stringstream items(text);
  std::string item;
  while (std::getline(items, item, ',')) {
    std::size_t used = 0;
    int value = 0;
    try {
      value = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size() || value < 1 || value > 100000) return false;
    counts.push_back(value);
  }
  return !counts.empty();
}

int run_verb(const Invocation& call) {
  return conclude_into(
      call, call.arguments[0], call.output_folder(""), core::run_outputs(),
      [&](core::StagedOutput&) {
        core::RunOptions options;
        options.stop = call.stop.token();
        return core::run_scene(call.scene_input(), options);
      },
      core::write_run);
}

int validate_verb(const Invocation& call) {
  return conclude(
      call.arguments[0], [&] { return core::validate_scene({call.scene_input()}); },
      [](const core::ValidationResult& result) { core::log_validation(result); });
}

// The study's adapter: `conclude_into`'s steps on every rank of `comm`. Rank 0 stages the
// output folder once every rank has validated the study (run_study calls stage_runs), writes
// the index and commits; every rank exits with rank 0's code.
int conclude_study(const Invocation& call, core::StudyRequest& request,
                   core::StudyCommunicator& comm) {
  const std::string subject = call.arguments[0];
  const fs::path folder = call.output_folder("-study");
  std::optional<core::StagedOutput> out;
  request.stage_runs = [&] {
    out.emplace(folder, core::study_outputs(), core::StagingControl(call.stop.token()));
    return out->path("runs");
  };
  request.write_run = core::write_run_folder;
  int code = core::kExitOk;
  try {
    const core::StudyResult result = core::run_study(request, comm);
    code = result.outcome.status;
    if (code >= 128) {
      spdlog::error("{}: {}; no output written", subject, result.outcome.message);
    } else if (result.leader && (code == core::kExitOk || code == core::kExitIncomplete)) {
      core::write_study(result, *out);
      out->commit();
      spdlog::info("wrote {}", folder.string());
    }
  } catch (...) {
    code = core::report_failure(subject);
  }
  out.reset();  // a staging left uncommitted is removed before the ranks part
  return comm.size() > 1 ? std::stoi(comm.broadcast(std::to_string(code))) : code;
}

int study_verb(const Invocation& call) {
  core::StudyRequest request;
  request.scene = call.scene_input();
  request.stop = call.stop.token();
  if (call.options.count("threads")) {
    request.threads = call.options["threads"].as<int>();
    if (request.threads < 0)
      return usage_error(call, "--threads takes a count >= 0 (0: one per core)");
  }
  if (!launched_by_mpi()) {
    core::StudyCommunicator serial;
    return conclude_study(call, request, serial);
  }
  auto mpi = make_mpi_communicator();
  if (!mpi) {
    spdlog::error(
        "frichb was started by an MPI launcher but built without MPI: every copy would run the "
        "whole study into the same folder. Install libopenmpi-dev and rebuild "
        "(scripts/setup.sh does), or run `frichb study` without mpirun.");
    return kExitUsage;
  }
  if (mpi->rank() > 0) {
    spdlog::default_logger()->set_pattern("[%H:%M:%S.%e] [rank " + std::to_string(mpi->rank()) +
                                          "] [%^%l%$] %v");
    if (spdlog::get_level() == spdlog::level::info) spdlog::set_level(spdlog::level::warn);
  }
  return conclude_study(call, request, *mpi);
}

int loop_verb(const Invocation& call) {
  return conclude_into(
      call, call.arguments[0], call.output_folder(""), core::loop_outputs(),
      [&](core::StagedOutput&) {
        return core::trace_loop({call.arguments[0], call.allow_scene_plugins});
      },
      core::write_loop);
}

int modes_verb(const Invocation& call) {
  core::ModesOptions request{call.scene_input(), 0.0, 0.0};
  if (call.options.count("rpm")) {
    const std::string text = call.options["rpm"].as<std::string>();
    const auto colon = text.find(':');
    try {
      request.rpm_low = std::stod(text.substr(0, colon));
      request.rpm_high =
          colon == std::string::npos ? request.rpm_low : std::stod(text.substr(colon + 1));
    } catch (const std::exception&) {
      request.rpm_low = -1;
    }
    if (!(request.rpm_low > 0 && request.rpm_high >= request.rpm_low))
      return usage_error(
          call,
          "--rpm takes a positive speed R or a range A:B with 0 < A <= B, not '" + text + "'");
  }
  return conclude_into(
      call, call.arguments[0], call.output_folder("-modes"), core::modes_outputs(),
      [&](core::StagedOutput&) { return core::compute_modes(request); }, core::write_modes);
}

// FROM:TO, two finite numbers written in full; nullopt otherwise.
std::optional<std::pair<double, double>> number_range(const std::string& text) {
  const auto colon = text.find(':');
  if (colon == std::string::npos) return std::nullopt;
  try {
    std::size_t used = 0;
    const std::string from = text.substr(0, colon), to = text.substr(colon + 1);
    const double low = std::stod(from, &used);
    if (used != from.size()) return std::nullopt;
    const double high = std::stod(to, &used);
    if (used != to.size() || !std::isfinite(low) || !std::isfinite(high)) return std::nullopt;
    return std::pair{low, high};
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// A,B,C: finite numbers written in full, separated by commas; nullopt otherwise.
std::optional<std::vector<double>> number_list(const std::string& text) {
  std::vector<double> values;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = text.find(',', begin);
    const std::string item = text.substr(begin, comma == std::string::npos ? comma : comma - begin);
    try {
      std::size_t used = 0;
      const double value = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(value)) return std::nullopt;
      values.push_back(value);
    } catch (const std::exception&) {
      return std::nullopt;
    }
    if (comma == std::string::npos) return values;
    begin = comma + 1;
  }
}

int peaks_verb(const Invocation& call) {
  core::PeaksOptions request;
  request.scene = call.scene_input();
  request.stop = call.stop.token();
  if (!call.options.count("vary"))
    return usage_error(call, "give the parameter and its range, --vary PATH=FROM:TO");
  const std::string vary = call.options["vary"].as<std::string>();
  const auto eq = vary.find('=');
  const auto range =
      eq == std::string::npos || eq == 0 ? std::nullopt : number_range(vary.substr(eq + 1));
  if (range) {
    request.parameter = vary.substr(0, eq);
    request.from = range->first;
    request.to = range->second;
  }
  if (!range || request.from == request.to)
    return usage_error(call,
                       "--vary takes PATH=FROM:TO with two different numbers, not '" + vary + "'");
  if (call.options.count("node")) request.node = call.options["node"].as<std::string>();
  if (call.options.count("near")) {
    request.near_hz = call.options["near"].as<double>();
    if (!(std::isfinite(*request.near_hz) && *request.near_hz > 0))
      return usage_error(call, "--near takes a frequency above 0 Hz");
  }
  if (call.options.count("check-runs")) {
    request.check_runs = call.options["check-runs"].as<int>();
    if (request.check_runs < 0) return usage_error(call, "--check-runs takes 0 or more");
  }
  request.normalise = call.options.count("normalise") > 0;
  if (call.options.count("axis")) {
    const std::string axis = call.options["axis"].as<std::string>();
    if (axis == "log")
      request.logarithmic = true;
    else if (axis == "linear")
      request.logarithmic = false;
    else if (axis != "auto")
      return usage_error(call, "--axis takes auto, linear or log, not '" + axis + "'");
    if (request.logarithmic.value_or(false) && !(std::min(request.from, request.to) > 0))
      return usage_error(call, "--axis log needs a range above 0");
  }
  return conclude_into(
      call, call.arguments[0], call.output_folder("-peaks"), core::peaks_outputs(),
      [&](core::StagedOutput&) { return core::track_peaks(request); }, core::write_peaks);
}

int nma_verb(const Invocation& call) {
  core::NmaOptions request;
  request.scene = call.scene_input();
  request.stop = call.stop.token();
  if (call.options.count("mode")) {
    request.mode = call.options["mode"].as<int>();
    if (request.mode < 1) return usage_error(call, "--mode counts from 1 (the lowest mode)");
  }
  if (call.options.count("amplitude")) {
    const std::string text = call.options["amplitude"].as<std::string>();
    const auto range = number_range(text);
    if (range) {
      request.from = range->first;
      request.to = range->second;
    }
    if (!range || !(*request.from > 0) || !(*request.to > *request.from))
      return usage_error(
          call, "--amplitude takes FROM:TO with 0 < FROM < TO (m sqrt(kg)), not '" + text + "'");
  }
  if (call.options.count("synthesise")) {
    const std::string text = call.options["synthesise"].as<std::string>();
    const auto levels = number_list(text);
    if (!levels || std::any_of(levels->begin(), levels->end(), [](double s) { return !(s > 0); }))
      return usage_error(call,
                         "--synthesise takes excitation levels S1,S2,... (multiples of the "
                         "scene's harmonic-1 excitation, each > 0), not '" +
                             text + "'");
    request.synthesise = *levels;
  }
  request.against_run = call.options.count("against-run") > 0;
  if (request.against_run && request.synthesise.empty())
    return usage_error(call, "--against-run compares syntheses: give --synthesise S1,S2,...");
  return conclude_into(
      call, call.arguments[0], call.output_folder("-nma"), core::nma_outputs(),
      [&](core::StagedOutput&) { return core::compute_nonlinear_modes(request); }, core::write_nma);
}

int timesim_verb(const Invocation& call) {
  if (!call.options.count("at-hz") || !(call.options["at-hz"].as<double>() > 0))
    return usage_error(call, "give the excitation frequency, --at-hz F (F > 0)");
  core::TimesimRequest request;
  request.scene = call.scene_input();
  request.integration.frequency_hz = call.options["at-hz"].as<double>();
  request.integration.stop = call.stop.token();
  return conclude_into(
      call, call.arguments[0], call.output_folder("-timesim"), core::timesim_outputs(),
      [&](core::StagedOutput&) { return core::integrate_scene(request); }, core::write_timesim);
}

int convergence_verb(const Invocation& call) {
  core::ConvergenceRequest request;
  request.scene = call.scene_input();
  request.time_integration = call.options.count("no-timesim") == 0;
  request.stop = call.stop.token();
  for (auto [key, list] :
       {std::pair{"harmonics", &request.harmonics}, std::pair{"samples", &request.samples},
        std::pair{"oversampling", &request.oversampling}}) {
    if (!call.options.count(key)) continue;
    const auto text = call.options[key].as<std::string>();
    if (!parse_counts(text, *list))
      return usage_error(call, std::string("--") + key +
                                   " takes integers from 1 to 100000 separated by commas, not '" +
                                   text + "'");
  }
  return conclude_into(
      call, call.arguments[0], call.output_folder("-convergence"), core::convergence_outputs(),
      [&](core::StagedOutput& out) {
        request.stage_runs = [&] { return out.path("runs"); };
        request.write_run = core::write_run_folder;
        return core::study_convergence(request);
      },
      core::write_convergence);
}

// The files each format needs besides the two matrices.
bool needs_equation_map(core::VendorFormat format) {
  return format != core::VendorFormat::kAbaqusMatrixInput;
}

int import_verb(const Invocation& call) {
  core::ImportRequest request;
  const std::string format = call.arguments[0];
  if (!core::parse_vendor_format(format, request.format))
    return usage_error(call, "unknown format '" + format +
                                 "': abaqus-matrix-input, abaqus-coordinate, ansys-hbmat or "
                                 "ansys-mmf");
  for (const char* required : {"stiffness", "mass", "nodes", "sectors"})
    if (!call.options.count(required))
      return usage_error(call, std::string("--") + required + " is required");
  if (call.output.empty()) return usage_error(call, "give the output folder, -o DIR");
  request.stiffness_file = call.options["stiffness"].as<std::string>();
  request.mass_file = call.options["mass"].as<std::string>();
  request.coordinates_file = call.options["nodes"].as<std::string>();
  if (needs_equation_map(request.format)) {
    if (!call.options.count("dof-map"))
      return usage_error(call, format + " needs the equation map, --dof-map FILE");
    request.equation_map_file = call.options["dof-map"].as<std::string>();
  } else if (call.options.count("dof-map")) {
    return usage_error(call, "abaqus-matrix-input names nodes and DOFs itself: no --dof-map");
  }
  request.sectors = call.options["sectors"].as<int>();
  if (request.sectors < 1) return usage_error(call, "--sectors takes a count >= 1");
  const auto units = call.options["units"].as<std::string>();
  if (!core::parse_unit_system(units, request.units))
    return usage_error(call, "--units takes SI or mm-t-s, not '" + units + "'");
  const auto frame = call.options["nodal-frames"].as<std::string>();
  if (!core::parse_nodal_frame(frame, request.nodal_frame))
    return usage_error(call, "--nodal-frames takes global or cylindrical, not '" + frame + "'");
  if (call.options.count("not-cyclic"))
    request.not_cyclic_file = call.options["not-cyclic"].as<std::string>();
  if (call.options.count("tolerance")) {
    request.tolerance = call.options["tolerance"].as<double>();
    if (!(request.tolerance > 0)) return usage_error(call, "--tolerance takes a length > 0");
  }
  return conclude_into(
      call, call.output, call.output, core::import_outputs(),
      [&](core::StagedOutput&) { return core::import_sector(request); }, core::write_import);
}

int plugins_verb(const Invocation& /*call*/) {
  return conclude(
      "", [] { return core::list_plugins({}); },
      [](const core::PluginsResult& result) { core::print_plugins(result, std::cout); });
}

int describe_verb(const Invocation& call) {
  return conclude(
      "", [&] { return core::describe({call.arguments[0]}); },
      [](const core::DescribeResult& result) { core::print_description(result, std::cout); });
}

int reference_verb(const Invocation& call) {
  return conclude(
      call.output, [] { return core::scene_reference({}); },
      [&](const core::ReferenceResult& result) {
        const std::string md = core::reference_markdown(result);
        if (call.output.empty()) {
          std::cout << md;
          return;
        }
        fs::create_directories(call.output);
        core::write_file(fs::path(call.output) / "scene-reference.md", md);
      });
}

Verb run_spec() {
  Verb v;
  v.name = "run";
  v.arguments = "SCENE.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one scene file";
  v.summary = "trace the response curve of a scene";
  v.description =
      "Traces the steady-state response of the scene over its frequency sweep (harmonic\n"
      "balance, arclength continuation through folds) and writes DIR/response.csv,\n"
      "response_harmonics.csv (each response DOF's harmonics at every point), summary.json\n"
      "(peaks, termination, resonance bands, timings), response.png and the friction\n"
      "loops of output.friction_loops_at; with output.contact_forces, contact_harmonics.csv\n"
      "(each contact's displacement and force harmonics at every point). A scene with a\n"
      "`mistuning` section is the whole mistuned disk (docs/mistuning.md): a column group per\n"
      "blade, and the tuned disk traced too for blade_peaks.csv/.png and the amplification in\n"
      "summary.json. The folder is replaced as a whole when the run succeeds and keeps its\n"
      "earlier results when it does not.";
  v.examples = {"frichb run configs/quickstart_friction_oscillator.yaml -o out/quickstart",
                "frichb run configs/two_dof_blade_damper.yaml --set "
                "contacts.platform_friction.params.mu=0.3 -v",
                "frichb run configs/bladed_disk_lumped_eo3_mistuned.yaml --set "
                "mistuning.deviations=[0.02,-0.02,0,0,0.01,0,-0.01,0]"};
  v.reads_scene = true;
  v.input_plugins = true;
  v.writes_output = true;
  v.output_default = "out/<scene file stem>";
  v.polls_interrupts = true;
  v.run = run_verb;
  return v;
}

Verb validate_spec() {
  Verb v;
  v.name = "validate";
  v.arguments = "SCENE.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one scene file";
  v.summary = "check a scene as run would before its first Newton iteration";
  v.description =
      "Reads the scene, loads its plugins (listing every file), builds the structure and\n"
      "the model, checks the contact-free response and the memory the scene needs, and\n"
      "does the same for every run of its study: section. Writes nothing. A scene that\n"
      "validates starts with run; a refusal names the file, line and key.";
  v.examples = {"frichb validate configs/two_dof_blade_damper.yaml"};
  v.reads_scene = true;
  v.input_plugins = true;
  v.run = validate_verb;
  return v;
}

Verb study_spec() {
  Verb v;
  v.name = "study";
  v.arguments = "SCENE.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one scene file with a study: section";
  v.summary = "run the scene's study: sweep on all cores (or MPI ranks)";
  v.description =
      "Runs the scene once for every value (grid or zip) of the keys its study: section\n"
      "sweeps, several at once, and writes DIR/study.csv, study.json, overlay.png,\n"
      "peak.png and runs/NNNN/ (each a run's outputs). Under `mpirun -n K` the runs are\n"
      "spread over K ranks (when built with MPI).";
  v.examples = {"frichb study configs/studies/damper_normal_load_sweep.yaml --threads 2",
                "mpirun -n 4 frichb study configs/studies/damper_normal_load_sweep.yaml"};
  v.reads_scene = true;
  v.input_plugins = true;
  v.writes_output = true;
  v.output_default = "out/<scene file stem>-study";
  v.polls_interrupts = true;
  v.add_options = [](po::options_description& d) {
    d.add_options()("threads", po::value<int>()->value_name("N"),
                    "threads per process (default: the scene's study.parallel; 0: one "
                    "per core)");
  };
  v.run = study_verb;
  return v;
}

Verb loop_spec() {
  Verb v;
  v.name = "loop";
  v.arguments = "INPUT.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one loop input file";
  v.summary = "trace one contact law under a prescribed relative motion";
  v.description =
      "Drives one contact law through the periodic relative motion the input prescribes\n"
      "and writes DIR/loop.csv (force against displacement over the period),\n"
      "harmonics.csv, summary.json and loop.png.";
  v.examples = {
      "frichb loop configs/friction_loops/fig3_4_2d_variable_normal_load.yaml -o "
      "out/fig3_4"};
  v.input_plugins = true;
  v.writes_output = true;
  v.output_default = "out/<input file stem>";
  v.polls_interrupts = true;
  v.run = loop_verb;
  return v;
}

Verb modes_spec() {
  Verb v;
  v.name = "modes";
  v.arguments = "SCENE.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one scene file";
  v.summary = "natural frequencies per harmonic index, nodal-diameter map";
  v.description =
      "Computes the natural frequencies of the structure (without contacts) for every\n"
      "harmonic index and writes them with the nodal-diameter map (ZZENF), with the\n"
      "engine-order excitation line at --rpm when given.";
  v.examples = {"frichb modes configs/bladed_disk_lumped_eo3.yaml --rpm 4000:8000"};
  v.reads_scene = true;
  v.input_plugins = true;
  v.writes_output = true;
  v.output_default = "out/<scene file stem>-modes";
  v.add_options = [](po::options_description& d) {
    d.add_options()("rpm", po::value<std::string>()->value_name("R|A:B"),
                    "rotation speed, rpm: one speed R, or a range A:B whose ends are "
                    "drawn");
  };
  v.run = modes_verb;
  return v;
}

Verb peaks_spec() {
  Verb v;
  v.name = "peaks";
  v.arguments = "SCENE.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one scene file";
  v.summary = "trace the resonance peak against a contact or excitation parameter";
  v.description =
      "Runs the scene at the start of the range, takes the solved peak of --node (the\n"
      "highest, or the one nearest --near), and continues that peak (the harmonic balance\n"
      "with the peak's stationarity along the response curve) to the end of the range,\n"
      "through folds of the peak curve. Where the peak ends (it merges with a valley), it\n"
      "goes on from the peak nearest it of a run 1 % further on. Runs at the range's end and\n"
      "at --check-runs points between show where another peak overtakes the traced one;\n"
      "that crossing is solved. Writes\n"
      "DIR/peaks.csv (parameter, peak frequency, peak amplitude, Newton iterations, and with\n"
      "the scene's output.stability whether the peak is stable), summary.json (the optimum:\n"
      "the lowest peak over the range; the jumps and exchanges; the sensitivities of the\n"
      "peak's frequency and amplitude to the parameter at every point) and peaks.png.\n"
      "The parameter is a scene path under contacts or excitation, as study sweeps name it.";
  v.examples = {
      "frichb peaks configs/peaks/planar_tip_normal_load.yaml --vary "
      "contacts.shroud.params.normal_load=1:100 -o out/planar_tip_peaks"};
  v.reads_scene = true;
  v.input_plugins = true;
  v.writes_output = true;
  v.output_default = "out/<scene file stem>-peaks";
  v.polls_interrupts = true;
  v.add_options = [](po::options_description& d) {
    d.add_options()("vary", po::value<std::string>()->value_name("PATH=FROM:TO"),
                    "the parameter (a scene path under contacts or excitation) and its range "
                    "(required)")(
        "node", po::value<std::string>()->value_name("NAME"),
        "the node whose peak is traced (default: the first of output.response)")(
        "near", po::value<double>()->value_name("HZ"),
        "trace the start run's peak nearest this frequency (default: its highest)")(
        "check-runs", po::value<int>()->value_name("N"),
        "ordinary runs at N traced points between the range's ends, where another peak may "
        "overtake the traced one (default 8; 0: none, only the start's, jumps' and end's)")(
        "axis", po::value<std::string>()->value_name("auto|linear|log"),
        "the parameter's axis (auto: log where the range is above 0 and spans a decade)")(
        "normalise",
        "the design chart against mu N0 / f (varying a contact's normal load; f: "
        "the one excitation's amplitude): two more columns, and the plot");
  };
  v.run = peaks_verb;
  return v;
}

Verb nma_spec() {
  Verb v;
  v.name = "nma";
  v.arguments = "SCENE.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one scene file";
  v.summary = "a nonlinear mode: frequency and damping ratio against amplitude";
  v.description =
      "Computes mode --mode of the structure with its contacts as a nonlinear mode (the\n"
      "extended periodic motion concept: the free motion made periodic by a negative\n"
      "mass-proportional damping, with the scene's harmonics, contacts and static loads,\n"
      "without its dynamic excitation), continued in the mode's amplitude from where the\n"
      "contacts stick. For a cyclic scene, the mode of the harmonic index the engine order\n"
      "excites, as a travelling wave. The amplitude a is the mode's fundamental modal\n"
      "coordinate (m sqrt(kg), mass-normalised modes); by default from where the contacts'\n"
      "largest motion is 1 nm to where it is 1 mm. Writes DIR/nma.csv (amplitude,\n"
      "frequency, damping ratio, energy the contacts dissipate per cycle, shares of the\n"
      "contacts' samples stuck, slipping and open, harmonic content), summary.json (the\n"
      "mode's frequencies without contacts and with them at rest, the most damped point)\n"
      "and nma.png.\n\n"
      "--synthesise S1,S2,... also synthesises the forced response to the scene's\n"
      "harmonic-1 excitation times each S from the backbone (single-nonlinear-mode theory,\n"
      "milliseconds a level), at the first output.response node, the mode alone and with\n"
      "the other retained modes as linear residual terms; each synthesised peak is checked\n"
      "by one harmonic-balance solve of the forced equations at its frequency, its error\n"
      "reported. --against-run also traces each level's full forced response (as frichb\n"
      "run, over the scene's frequency range) for the synthesis's error at the peak and\n"
      "the cost of both. Writes synthesis.csv (the curves), synthesis_peaks.csv (peaks,\n"
      "checks, full runs) and synthesis.png. Synthesis holds near an isolated resonance at\n"
      "light friction damping: docs/validation.md gives its error against the damping.";
  v.examples = {
      "frichb nma configs/two_dof_blade_damper.yaml --mode 1 -o out/damper_nma",
      "frichb nma configs/two_dof_blade_damper.yaml --synthesise 0.001,0.05,0.2 --against-run "
      "-o out/damper_synthesis"};
  v.reads_scene = true;
  v.input_plugins = true;
  v.writes_output = true;
  v.output_default = "out/<scene file stem>-nma";
  v.polls_interrupts = true;
  v.add_options = [](po::options_description& d) {
    d.add_options()("mode", po::value<int>()->value_name("K"),
                    "the mode, 1 for the structure's lowest at harmonic 1 (default 1)")(
        "amplitude", po::value<std::string>()->value_name("FROM:TO"),
        "the range of the modal amplitude a, m sqrt(kg), traced on a log axis (default: "
        "contact motion from 1 nm to 1 mm)")(
        "synthesise", po::value<std::string>()->value_name("S1,S2,..."),
        "forced responses synthesised from the backbone at these multiples of the scene's "
        "harmonic-1 excitation, each peak checked by a harmonic-balance solve")(
        "against-run", "also trace each level's full forced response, for the error and cost");
  };
  v.run = nma_verb;
  return v;
}

Verb timesim_spec() {
  Verb v;
  v.name = "timesim";
  v.arguments = "SCENE.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one scene file";
  v.summary = "time-integration reference at one frequency (plain structures)";
  v.description =
      "Integrates the equations of motion in time at one excitation frequency until the\n"
      "response is periodic and writes DIR/timesim.csv (the last period) and\n"
      "summary.json: the reference the harmonic balance is checked against.";
  v.examples = {
      "frichb timesim configs/two_dof_blade_damper.yaml --at-hz 298 -o "
      "out/two_dof_ts"};
  v.reads_scene = true;
  v.input_plugins = true;
  v.writes_output = true;
  v.output_default = "out/<scene file stem>-timesim";
  v.polls_interrupts = true;
  v.add_options = [](po::options_description& d) {
    d.add_options()("at-hz", po::value<double>()->value_name("F"),
                    "excitation frequency, Hz (required)");
  };
  v.run = timesim_verb;
  return v;
}

Verb convergence_spec() {
  Verb v;
  v.name = "convergence";
  v.arguments = "SCENE.yaml";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "one scene file";
  v.summary = "peak error against harmonics, samples and run time";
  v.description =
      "Runs the scene at every setting (N >= 2H+1), one after the other, and reports the\n"
      "error in peak amplitude and frequency against the finest setting and against time\n"
      "integration, with the wall time: DIR/convergence.csv, .json, .md and .png.";
  v.examples = {
      "frichb convergence configs/two_dof_blade_damper.yaml --harmonics 1,3,5,7 "
      "--samples 64,256"};
  v.reads_scene = true;
  v.input_plugins = true;
  v.writes_output = true;
  v.output_default = "out/<scene file stem>-convergence";
  v.polls_interrupts = true;
  v.add_options = [](po::options_description& d) {
    d.add_options()("harmonics", po::value<std::string>()->value_name("H,H,..."),
                    "largest kept harmonics (default 1,3,5,7,10,15)")(
        "samples", po::value<std::string>()->value_name("N,N,..."),
        "samples per period (default 64,128,256,512,1024,2048)")(
        "oversampling", po::value<std::string>()->value_name("K,K,..."),
        "trace oversampling factors (default 1,4)")("no-timesim",
                                                    "skip the time-integration reference");
  };
  v.run = convergence_verb;
  return v;
}

Verb import_spec() {
  Verb v;
  v.name = "import";
  v.arguments = "FORMAT";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments =
      "one format: abaqus-matrix-input, abaqus-coordinate, ansys-hbmat or ansys-mmf";
  v.summary = "turn an ANSYS or Abaqus sector export into fe_sector's files";
  v.description =
      "Reads a sector's stiffness and mass matrices exported by Abaqus or ANSYS (FORMAT:\n"
      "abaqus-matrix-input: *MATRIX OUTPUT, FORMAT=MATRIX INPUT, lines 'node, dof, node,\n"
      "dof, value'; abaqus-coordinate: FORMAT=COORDINATE, 'row, column, value' with the\n"
      "equation map --dof-map; ansys-hbmat: HBMAT Harwell-Boeing ASCII with its .mapping\n"
      "file; ansys-mmf: APDL Math *EXPORT,,MMF with the .mapping file) and the node\n"
      "coordinates (--nodes: a .csv 'node,x,y,z', an Abaqus .inp's *NODE blocks, or any\n"
      "other name: ANSYS NWRITE output). Converts the units once (--units mm-t-s: N/mm,\n"
      "t, mm to N/m, kg, m), turns each node's DOFs from the global frame into its\n"
      "cylindrical frame (r, theta, z) about z (--nodal-frames global: K' = T^T K T),\n"
      "pairs the cyclic boundary by position (node R is the partner of node L when R is\n"
      "L turned by +2 pi/sectors about z within --tolerance; default 1e-6 of the largest\n"
      "coordinate) and writes DIR/sector_stiffness.mtx, sector_mass.mtx (Matrix Market,\n"
      "SI, lower triangle), cyclic_pairs.txt, mesh.yaml and nodes.csv, for the fe_sector\n"
      "provider. Refused, with file and line: rotational DOFs, internal nodes (Lagrange\n"
      "multipliers), unsymmetric matrices, nodes without coordinates, an unpaired or\n"
      "doubly paired boundary. docs/fe-models.md walks through both vendors.";
  v.examples = {
      "frichb import abaqus-matrix-input --stiffness blade_STIF2.mtx --mass blade_MASS2.mtx "
      "--nodes blade.inp --sectors 24 --units mm-t-s -o model",
      "frichb import ansys-hbmat --stiffness k.matrix --mass m.matrix --dof-map k.mapping "
      "--nodes sector.node --sectors 24 --nodal-frames cylindrical -o model"};
  v.writes_output = true;
  v.output_default = "none, required";
  v.add_options = [](po::options_description& d) {
    d.add_options()("stiffness", po::value<std::string>()->value_name("FILE"),
                    "the stiffness matrix file (required)")(
        "mass", po::value<std::string>()->value_name("FILE"), "the mass matrix file (required)")(
        "dof-map", po::value<std::string>()->value_name("FILE"),
        "equation -> node, DOF map: 'equation node dof' lines, DOF a number or UX/UY/UZ (the "
        "ANSYS .mapping file); all formats but abaqus-matrix-input")(
        "nodes", po::value<std::string>()->value_name("FILE"),
        "node coordinates: .csv (node,x,y,z), .inp (Abaqus *NODE) or NWRITE output (required)")(
        "sectors", po::value<int>()->value_name("N"),
        "sectors of the full disk; the sector angle is 2 pi / N (required)")(
        "units", po::value<std::string>()->default_value("SI")->value_name("SI|mm-t-s"),
        "units of the exported files; written files are always SI")(
        "nodal-frames",
        po::value<std::string>()->default_value("global")->value_name("global|cylindrical"),
        "frame of each node's DOFs in the export: global (x, y, z; turned into r, theta, z) "
        "or cylindrical (r, theta, z about the global z axis, kept)")(
        "tolerance", po::value<double>()->value_name("L"),
        "cyclic pairing distance, in the coordinates' units (default 1e-6 of the largest "
        "coordinate magnitude)")(
        "not-cyclic", po::value<std::string>()->value_name("FILE"),
        "node numbers never paired across the cyclic boundary (contact faces that coincide "
        "with the neighbour's at rest, e.g. shroud interfaces); blanks/commas, # comments");
  };
  v.run = import_verb;
  return v;
}

Verb plugins_spec() {
  Verb v;
  v.name = "plugins";
  v.missing_arguments = "no argument";
  v.summary = "list the plugins found on the search path";
  v.description =
      "Lists the plugin search path and every plugin found on "
      "it: name, kind, version, summary and file.";
  v.examples = {"frichb plugins"};
  v.run = plugins_verb;
  return v;
}

Verb describe_spec() {
  Verb v;
  v.name = "describe";
  v.arguments = "NAME";
  v.min_arguments = 1;
  v.max_arguments = 1;
  v.missing_arguments = "a plugin name (or 'scene')";
  v.summary = "parameter table of a plugin ('scene': the core keys)";
  v.description =
      "Prints a plugin's version, file and parameter table (name, type, unit,\n"
      "default, range), or with 'scene' the tables of the core sections.";
  v.examples = {"frichb describe coupled_3d", "frichb describe scene"};
  v.run = describe_verb;
  return v;
}

Verb reference_spec() {
  Verb v;
  v.name = "reference";
  v.missing_arguments = "no argument";
  v.summary = "the scene reference (Markdown) from every schema";
  v.description =
      "Writes the scene reference generated from the schemas of "
      "the core and of every plugin\nfound, to standard output "
      "or to DIR/scene-reference.md.";
  v.examples = {"frichb reference -o docs"};
  v.writes_output = true;
  v.output_default = "standard output";
  v.run = reference_verb;
  return v;
}

}  // namespace

const std::vector<Verb>& verbs() {
  static const std::vector<Verb> list = {
      run_spec(),     validate_spec(), study_spec(),    loop_spec(),        modes_spec(),
      nma_spec(),     peaks_spec(),    timesim_spec(),  convergence_spec(), import_spec(),
      plugins_spec(), describe_spec(), reference_spec()};
  return list;
}

}  // namespace frichb::app
