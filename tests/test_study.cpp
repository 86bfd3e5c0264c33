// Studies: path addressing, validation of every run before any computes, and runs that give
// the same answers as the same scene edited by hand, whatever the thread count.
//
// Oracles: the quick-start oscillator with its contact stuck (huge normal load) is the linear
// system with kt added to the stiffness, and with mu = 0 it is the free system; both peaks
// are computed here from the closed-form FRF of one DOF with modal damping.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <regex>
#include <sstream>

#include "frichb/core/commands/convergence.hpp"
#include "frichb/core/commands/study.hpp"
#include "frichb/core/report/convergence_report.hpp"
#include "frichb/core/report/run_report.hpp"
#include "frichb/core/report/study_report.hpp"
#include "frichb/core/support/output.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;
using frichb::test::TempDir;
using namespace frichb::core;
using ::testing::HasSubstr;

// A study as the command line runs it: the output folder staged once every rank has
// validated, each run written into runs/NNNN/, the index written and committed by rank 0.
// Returns the study's exit code.
int study_into(const fs::path& scene, const fs::path& folder, int threads,
               StudyCommunicator& comm) {
  StudyRequest request;
  request.scene.file = scene;
  request.threads = threads;
  std::optional<StagedOutput> out;
  request.stage_runs = [&] {
    out.emplace(folder, study_outputs());
    return out->path("runs");
  };
  request.write_run = write_run_folder;
  const StudyResult result = run_study(request, comm);
  const int code = result.outcome.status;
  if (result.leader && (code == kExitOk || code == kExitIncomplete)) {
    write_study(result, *out);
    out->commit();
  }
  return code;
}

const fs::path kQuickstart =
    fs::path(FRICHB_SOURCE_DIR) / "configs" / "quickstart_friction_oscillator.yaml";

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The quick-start scene without plots and loops, with `study` appended.
fs::path quickstart_with_study(const TempDir& dir, const std::string& study,
                               const std::string& name = "scene.yaml") {
  std::string text = read_text(kQuickstart);
  text = std::regex_replace(text, std::regex("friction_loops_at: \\[[^\\]]*\\]"),
                            "friction_loops_at: []");
  text = std::regex_replace(text, std::regex("plots: true"), "plots: false");
  return dir.write(name, text + "\n" + study);
}

std::vector<std::vector<std::string>> read_csv(const fs::path& file) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

// The study.csv without its wall-time column (the only one that may differ between runs).
std::string without_wall_time(const fs::path& csv) {
  std::string out;
  for (auto row : read_csv(csv)) {
    row.pop_back();
    for (const auto& c : row) out += c + ",";
    out += "\n";
  }
  return out;
}

// Peak amplitude of m x'' + c x' + k x = F cos wt over w (golden section around sqrt(k/m)).
double linear_peak(double m, double c, double k, double force) {
  auto amp = [&](double w) { return force / std::abs(std::complex<double>(k - m * w * w, c * w)); };
  double a = 0.9 * std::sqrt(k / m), b = 1.1 * std::sqrt(k / m);
  for (int i = 0; i < 200; ++i) {
    const double c1 = b - 0.618 * (b - a), c2 = a + 0.618 * (b - a);
    (amp(c1) > amp(c2) ? b : a) = amp(c1) > amp(c2) ? c2 : c1;
  }
  return amp(0.5 * (a + b));
}

TEST(StudyPath, SetsContactsByNameListEntriesAndMissingKeys) {
  YAML::Node doc = YAML::Load(
      "contacts:\n  - {name: a, params: {mu: 0.1}}\n  - {name: b, params: {mu: 0.2}}\n"
      "structure: {params: {masses: [1, 2, 3]}}\n");
  set_scene_value(doc, "contacts.b.params.mu", 0.7);
  set_scene_value(doc, "structure.params.masses[1]", 5.5);
  set_scene_value(doc, "contacts[0].params.kt", 2e5);  // absent: created
  set_scene_value(doc, "contacts.0.params.mu", 0.3);   // a number is a list index too
  EXPECT_DOUBLE_EQ(doc["contacts"][1]["params"]["mu"].as<double>(), 0.7);
  EXPECT_DOUBLE_EQ(doc["contacts"][0]["params"]["mu"].as<double>(), 0.3);
  EXPECT_DOUBLE_EQ(doc["structure"]["params"]["masses"][1].as<double>(), 5.5);
  EXPECT_EQ(doc["structure"]["params"]["masses"].size(), 3u);
  EXPECT_EQ(doc["contacts"][0]["params"]["kt"].Scalar(), "200000");  // integral: an integer
}

TEST(StudyPath, UnresolvablePathsSayWhy) {
  YAML::Node doc = YAML::Load(
      "contacts:\n  - {name: shroud, params: {mu: 0.1}}\nstructure: {params: {masses: [1]}}\n");
  auto message = [&](const std::string& path) {
    try {
      set_scene_value(doc, path, 1.0);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(message("contacts.shrod.params.mu"), HasSubstr("did you mean 'shroud'"));
  EXPECT_THAT(message("structure.params.masses[3]"), HasSubstr("has 1 entries"));
  EXPECT_THAT(message("structure.params"), HasSubstr("is a map, not a number"));
  EXPECT_THAT(message("structure.parms.masses"), HasSubstr("did you mean 'params'"));
  EXPECT_THAT(message("contacts.shroud..mu"), HasSubstr("empty key"));
}

TEST(StudySpec, GridZipAndRangesExpandToRuns) {
  TempDir dir;
  const auto file = quickstart_with_study(
      dir,
      "study:\n  sweep:\n"
      "    - {path: contacts.root_friction.params.normal_load, values: [1, 2, 3]}\n"
      "    - {path: excitation.0.amplitude, from: 1, to: 100, count: 3, spacing: log}\n");
  Scene scene = load_scene(file);
  const Registry registry(Registry::default_search_path());
  bind_plugins(scene, registry);
  const auto study = load_study(scene);
  ASSERT_EQ(study.sweeps.size(), 2u);
  EXPECT_NEAR(study.sweeps[1].values[1], 10.0, 1e-12);
  const auto runs = prepare_study_runs(scene, study, registry);
  ASSERT_EQ(runs.size(), 9u);  // grid: 3 x 3, the first sweep slowest
  EXPECT_EQ(runs[4].id, "0004");
  EXPECT_DOUBLE_EQ(runs[4].values[0], 2.0);
  EXPECT_NEAR(runs[4].values[1], 10.0, 1e-12);
  EXPECT_NEAR(runs[4].scene.excitation[0].amplitude, 10.0, 1e-12);
  EXPECT_EQ(runs[4].scene.contacts[0].values.to_json(
                runs[4].scene.contacts[0].plugin->schema())["normal_load"],
            2.0);

  const auto zipped = quickstart_with_study(
      dir,
      "study:\n  combine: zip\n  sweep:\n"
      "    - {path: contacts.root_friction.params.normal_load, values: [1, 2, 3]}\n"
      "    - {path: contacts.root_friction.params.mu, values: [0.1, 0.2, 0.3]}\n",
      "zip.yaml");
  Scene zs = load_scene(zipped);
  bind_plugins(zs, registry);
  EXPECT_EQ(prepare_study_runs(zs, load_study(zs), registry).size(), 3u);

  // Load cases (a preload and a friction coefficient varying together) on a grid with the
  // excitation level: 3 cases x 2 levels, the cases slowest, each case's pair kept together.
  const auto cases = quickstart_with_study(
      dir,
      "study:\n  sweep:\n"
      "    - {path: contacts.root_friction.params.normal_load, values: [1, 2, 3]}\n"
      "    - {path: contacts.root_friction.params.mu, values: [0.1, 0.2, 0.3], "
      "with_previous: true}\n"
      "    - {path: excitation.0.amplitude, values: [5, 7]}\n",
      "cases.yaml");
  Scene cs = load_scene(cases);
  bind_plugins(cs, registry);
  const auto case_study = load_study(cs);
  ASSERT_EQ(case_study.axes().size(), 2u);
  EXPECT_EQ(case_study.axes()[0], (std::vector<std::size_t>{0, 1}));
  const auto case_runs = prepare_study_runs(cs, case_study, registry);
  ASSERT_EQ(case_runs.size(), 6u);
  const std::vector<std::vector<double>> expected = {{1, 0.1, 5}, {1, 0.1, 7}, {2, 0.2, 5},
                                                     {2, 0.2, 7}, {3, 0.3, 5}, {3, 0.3, 7}};
  for (std::size_t r = 0; r < expected.size(); ++r) {
    EXPECT_EQ(case_runs[r].values, expected[r]) << "run " << r;
    EXPECT_EQ(case_runs[r].scene.contacts[0].values.to_json(
                  case_runs[r].scene.contacts[0].plugin->schema())["mu"],
              expected[r][1]);
  }
}

// The error text of preparing every run of the quick-start scene with `study` appended
// ("no error" when it is accepted).
std::string study_error(const TempDir& dir, const std::string& study) {
  const Registry registry(Registry::default_search_path());
  const auto file = quickstart_with_study(dir, study);
  try {
    Scene scene = load_scene(file);
    bind_plugins(scene, registry);
    prepare_study_runs(scene, load_study(scene), registry);
  } catch (const SceneError& e) {
    return std::string(e.what());
  }
  return std::string("no error");
}

TEST(StudySpec, BadInputNamesFileLineAndRun) {
  TempDir dir;
  auto error_of = [&](const std::string& study) { return study_error(dir, study); };
  // A typo in the path: located at the path, with the closest key.
  EXPECT_THAT(error_of("study:\n  sweep:\n    - {path: contacts.root_friction.params.normal_lod, "
                       "values: [1]}\n"),
              ::testing::ContainsRegex("scene.yaml:[0-9]+:[0-9]+: study.sweep\\[0\\]: "
                                       ".*normal_lod.*did you mean 'normal_load'"));
  // A value outside its key's range, found before any run computes, naming the run.
  EXPECT_THAT(
      error_of("study:\n  sweep:\n    - {path: contacts.root_friction.params.mu, "
               "values: [0.5, -1]}\n"),
      ::testing::AllOf(HasSubstr("scene.yaml:"), HasSubstr("mu"), HasSubstr("study run 0001")));
  EXPECT_THAT(error_of("study:\n  combine: zip\n  sweep:\n"
                       "    - {path: contacts.root_friction.params.mu, values: [0.1, 0.2]}\n"
                       "    - {path: excitation.0.amplitude, values: [1]}\n"),
              HasSubstr("equal lengths"));
  EXPECT_THAT(error_of("study:\n  sweep:\n"
                       "    - {path: contacts.root_friction.params.mu, values: [0.1, 0.2]}\n"
                       "    - {path: excitation.0.amplitude, values: [1], with_previous: true}\n"),
              HasSubstr("study.sweep[1]: with_previous needs sweeps of equal lengths (2 and 1"));
  EXPECT_THAT(error_of("study:\n  sweep:\n"
                       "    - {path: excitation.0.amplitude, values: [1], with_previous: true}\n"),
              HasSubstr("study.sweep[0].with_previous: the first sweep has no previous sweep"));
  EXPECT_THAT(error_of("study:\n  sweep:\n    - {path: excitation.0.amplitude, from: 1}\n"),
              HasSubstr("needs from, to and count"));
  EXPECT_THAT(error_of("study:\n  parallel: many\n  sweep:\n"
                       "    - {path: excitation.0.amplitude, values: [1]}\n"),
              HasSubstr("study.parallel"));
}

// Input hardening (docs/validation.md): a list index beyond unsigned long escaped load_study as
// std::out_of_range (`frichb validate` exited 4, internal error), and a huge count or grid
// allocated gigabytes of values and runs before anything was checked.
TEST(StudySpec, HugeIndicesCountsAndGridsAreInputErrors) {
  TempDir dir;
  auto error_of = [&](const std::string& sweep) {
    return study_error(dir, "study:\n  sweep:\n" + sweep);
  };
  EXPECT_THAT(error_of("    - {path: excitation.99999999999999999999.amplitude, values: [1]}\n"),
              ::testing::AllOf(HasSubstr("study.sweep[0].path: "),
                               HasSubstr("99999999999999999999 is not a list index")));
  EXPECT_THAT(
      error_of("    - {path: \"excitation[99999999999999999999].amplitude\", values: [1]}\n"),
      HasSubstr("99999999999999999999 is not a list index"));
  EXPECT_THAT(error_of("    - {path: excitation.0.amplitude, from: 1, to: 2, count: 1e6}\n"),
              HasSubstr("study.sweep[0].count: value 1e+06 violates count <= 100000"));
  EXPECT_THAT(
      error_of("    - {path: excitation.0.amplitude, from: 1, to: 2, count: 1000}\n"
               "    - {path: contacts.root_friction.params.mu, from: 0, to: 1, count: 1000}\n"),
      HasSubstr("study.sweep: more than 100000 runs"));
}

// Each run equals `frichb run` on the scene edited by hand, and the fully stuck and fully
// free limits equal the closed-form linear peaks.
TEST(StudyRun, RunsMatchHandEditedScenesAndLinearLimits) {
  TempDir dir;
  const auto file = quickstart_with_study(
      dir,
      "study:\n  combine: zip\n  parallel: 2\n  sweep:\n"
      "    - {path: contacts.root_friction.params.normal_load, values: [1.0e6, 5.0, 5.0]}\n"
      "    - {path: contacts.root_friction.params.mu, values: [0.5, 0.5, 0.0]}\n");
  StudyCommunicator serial;
  ASSERT_EQ(study_into(file, dir.path() / "study", -1, serial), kExitOk);
  const auto index = nlohmann::json::parse(read_text(dir.path() / "study" / "study.json"));
  ASSERT_EQ(index["runs"].size(), 3u);
  const double peak_stuck = index["runs"][0]["peak"]["blade"]["amplitude_m"].get<double>();
  const double peak_friction = index["runs"][1]["peak"]["blade"]["amplitude_m"].get<double>();
  const double peak_free = index["runs"][2]["peak"]["blade"]["amplitude_m"].get<double>();

  // The quick-start oscillator: m = 0.1 kg, k = 4e5 N/m, modal damping 0.005 of the free
  // mode, F = 2 N, kt = 2e5 N/m.
  const double m = 0.1, k = 4e5, kt = 2e5, force = 2.0;
  const double c = 2 * 0.005 * std::sqrt(k / m) * m;
  EXPECT_NEAR(peak_stuck / linear_peak(m, c, k + kt, force), 1.0, 1e-5);
  EXPECT_NEAR(peak_free / linear_peak(m, c, k, force), 1.0, 1e-5);
  EXPECT_LT(peak_friction, 0.5 * peak_free);

  // Run 0001 is the quick-start scene as shipped (normal load 5 N, mu 0.5): `frichb run`.
  const auto plain = quickstart_with_study(dir, "", "plain.yaml");
  const RunResult plain_run = run_scene(SceneInput{plain, {}, false});
  ASSERT_EQ(plain_run.outcome.status, kExitOk);
  write_run_folder(plain_run, dir.path() / "plain");
  const auto single = nlohmann::json::parse(read_text(dir.path() / "plain" / "summary.json"));
  EXPECT_EQ(single["peak"]["blade"]["amplitude_m"].get<double>(), peak_friction);
  EXPECT_EQ(read_text(dir.path() / "plain" / "response.csv"),
            read_text(dir.path() / "study" / "runs" / "0001" / "response.csv"));
  const auto member =
      nlohmann::json::parse(read_text(dir.path() / "study" / "runs" / "0001" / "summary.json"));
  EXPECT_EQ(member["study"]["run"], "0001");
  EXPECT_EQ(member["study"]["parameters"]["contacts.root_friction.params.mu"], 0.5);
  EXPECT_EQ(index["optimum"]["run"], "0001");
}

// With output.stability the overlay draws each run's stable points solid over its whole curve
// dashed: on the Hertz gap scene at two friction coefficients, both runs have unstable points,
// and the overlay's script reads their `stable` column.
TEST(StudyRun, OverlayDashesEachRunsUnstableBranches) {
  TempDir dir;
  std::string text = read_text(fs::path(FRICHB_SOURCE_DIR) / "configs/stress/hertz_gap_folds.yaml");
  text = std::regex_replace(text, std::regex("plots: false"), "plots: true");
  const auto file =
      dir.write("gap.yaml", text +
                                "study:\n  sweep:\n    - {path: contacts.shroud.params.mu, values: "
                                "[0.3, 0.25]}\n");
  StudyCommunicator serial;
  ASSERT_EQ(study_into(file, dir.path() / "study", 1, serial), kExitOk);
  const std::string gp = read_text(dir.path() / "study" / "overlay.gp");
  for (const char* run : {"0000", "0001"}) {
    const std::string csv = std::string("'runs/") + run + "/response.csv'";
    EXPECT_NE(gp.find(csv + " using 2:(column('stable') > 0.5 ? "), std::string::npos) << gp;
    const auto rows = read_csv(dir.path() / "study" / "runs" / run / "response.csv");
    const auto stable = std::find(rows[0].begin(), rows[0].end(), "stable") - rows[0].begin();
    ASSERT_LT(static_cast<std::size_t>(stable), rows[0].size());
    EXPECT_TRUE(
        std::any_of(rows.begin() + 1, rows.end(),
                    [&](const auto& row) { return row[static_cast<std::size_t>(stable)] == "0"; }))
        << run << " has no unstable point";
  }
  EXPECT_NE(gp.find("title 'unstable (dashed)'"), std::string::npos);
  EXPECT_TRUE(fs::is_regular_file(dir.path() / "study" / "overlay.png"));
}

// The quick-start scene with its normal load and name taken from the variable n0.
fs::path quickstart_with_variable(const TempDir& dir, const std::string& study,
                                  const std::string& name = "variables.yaml") {
  std::string text = read_text(quickstart_with_study(dir, study, name));
  text = std::regex_replace(text, std::regex("params: \\{kt: 2.0e5, mu: 0.5, normal_load: 5.0\\}"),
                            "params:\n      kt: 2.0e5\n      mu: 0.5\n      normal_load: ${n0}");
  text = std::regex_replace(text, std::regex("name: friction_oscillator"),
                            "name: oscillator_${n0}_N\nvariables: {n0: 5.0}");
  return dir.write(name, text);
}

// A swept scene variable gives the runs of the keys it stands for, swept by hand.
TEST(StudyRun, SweptVariablesAreTheKeysTheyStandFor) {
  TempDir dir;
  const auto by_variable = quickstart_with_variable(
      dir, "study:\n  sweep:\n    - {path: variables.n0, values: [1.0e6, 5]}\n");
  ASSERT_NE(read_text(by_variable).find("normal_load: ${n0}"), std::string::npos);
  const auto by_key = quickstart_with_study(
      dir,
      "study:\n  sweep:\n"
      "    - {path: contacts.root_friction.params.normal_load, values: [1.0e6, 5]}\n",
      "keys.yaml");
  StudyCommunicator serial;
  ASSERT_EQ(study_into(by_variable, dir.path() / "variable", 1, serial), kExitOk);
  ASSERT_EQ(study_into(by_key, dir.path() / "key", 1, serial), kExitOk);
  for (const char* run : {"0000", "0001"})
    EXPECT_EQ(read_text(dir.path() / "variable" / "runs" / run / "response.csv"),
              read_text(dir.path() / "key" / "runs" / run / "response.csv"))
        << run;
  // Stuck (1e6 N): the linear oscillator with kt added to its spring.
  const auto index = nlohmann::json::parse(read_text(dir.path() / "variable" / "study.json"));
  const double m = 0.1, k = 4e5, kt = 2e5, force = 2.0;
  const double c = 2 * 0.005 * std::sqrt(k / m) * m;
  EXPECT_NEAR(index["runs"][0]["peak"]["blade"]["amplitude_m"].get<double>() /
                  linear_peak(m, c, k + kt, force),
              1.0, 1e-5);
  // Text values take the variable as the study wrote it.
  const auto member =
      nlohmann::json::parse(read_text(dir.path() / "variable" / "runs" / "0001" / "summary.json"));
  EXPECT_EQ(member["scene"]["name"], "oscillator_5_N");
}

TEST(SceneVariables, BadReferencesAndDefinitionsNameFileLineAndKey) {
  TempDir dir;
  int line_of_change = 0;  // 1-based line of the replaced text
  auto error_of = [&](const std::string& from, const std::string& to) {
    std::string text = read_text(quickstart_with_variable(dir, ""));
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    line_of_change = 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
    text.replace(at, from.size(), to);
    try {
      Scene scene = load_scene(dir.write("bad.yaml", text));
      bind_plugins(scene, frichb::test::built_plugins());
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string unknown = error_of("normal_load: ${n0}", "normal_load: ${N0}");
  EXPECT_THAT(unknown, HasSubstr("bad.yaml:" + std::to_string(line_of_change) + ":"));
  EXPECT_THAT(unknown, ::testing::ContainsRegex("contacts\\[0\\].params.normal_load: .*unknown "
                                                "variable 'N0' \\(variables: n0\\)"));
  EXPECT_THAT(error_of("      mu: 0.5", "      mu_${n0}: 0.5"),
              HasSubstr("a key cannot hold a variable"));
  EXPECT_THAT(error_of("normal_load: ${n0}", "normal_load: ${n0"),
              HasSubstr("without its closing"));
  EXPECT_THAT(error_of("variables: {n0: 5.0}", "variables: {2n: 5.0}"),
              HasSubstr("'2n' is not a variable name"));
  EXPECT_THAT(error_of("variables: {n0: 5.0}", "variables: {n0: [5.0]}"),
              HasSubstr("variables.n0: a variable holds one value"));
  EXPECT_THAT(error_of("variables: {n0: 5.0}", "variables: {n0: '${n0}'}"),
              HasSubstr("cannot refer to a variable"));
  EXPECT_THAT(error_of("variables: {n0: 5.0}", "variables: [5.0]"),
              HasSubstr("variables: a map of names to values"));
  // A substituted value is read like one written by hand: its key's checks still apply.
  EXPECT_THAT(error_of("variables: {n0: 5.0}", "variables: {n0: -5.0}"), HasSubstr("normal_load"));
  EXPECT_EQ(error_of("variables: {n0: 5.0}", "variables: {n0: 7.5}"), "no error");
}

TEST(StudyRun, OneThreadAndTwoThreadsWriteTheSameIndex) {
  TempDir dir;
  const auto file = quickstart_with_study(
      dir,
      "study:\n  sweep:\n"
      "    - {path: contacts.root_friction.params.normal_load, values: [2, 5]}\n"
      "    - {path: excitation.0.amplitude, values: [1, 3]}\n");
  StudyCommunicator serial;
  ASSERT_EQ(study_into(file, dir.path() / "one", 1, serial), kExitOk);
  ASSERT_EQ(study_into(file, dir.path() / "two", 2, serial), kExitOk);
  EXPECT_EQ(without_wall_time(dir.path() / "one" / "study.csv"),
            without_wall_time(dir.path() / "two" / "study.csv"));
  for (const char* run : {"0000", "0001", "0002", "0003"})
    EXPECT_EQ(read_text(dir.path() / "one" / "runs" / run / "response.csv"),
              read_text(dir.path() / "two" / "runs" / run / "response.csv"))
        << run;
  // The peak falls as the normal load rises at 1 N, and rises with the excitation.
  const auto rows = read_csv(dir.path() / "one" / "study.csv");
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_LT(std::stod(rows[1][6]), std::stod(rows[2][6]));  // (2 N, 1 N) below (2 N, 3 N)
}

TEST(StudyRun, InvalidStudyWritesNothing) {
  TempDir dir;
  const auto file = quickstart_with_study(
      dir, "study:\n  sweep:\n    - {path: contacts.root_friction.params.kt, values: [1, -5]}\n");
  StudyCommunicator serial;
  EXPECT_EQ(study_into(file, dir.path() / "out", -1, serial), kExitInvalidInput);
  EXPECT_FALSE(fs::exists(dir.path() / "out"));
}

TEST(StudySpec, GeneratedRangesEndExactlyWhereWritten) {
  // 0.1 + (0.3 - 0.1) * 1 is 0.30000000000000004 in doubles; the last value is the `to`
  // the user wrote, linear or log.
  TempDir dir;
  const auto file = quickstart_with_study(
      dir,
      "study:\n  combine: zip\n  sweep:\n"
      "    - {path: contacts.root_friction.params.mu, from: 0.1, to: 0.3, count: 3}\n"
      "    - {path: excitation.0.amplitude, from: 0.3, to: 0.7, count: 3, spacing: log}\n");
  Scene scene = load_scene(file);
  const auto study = load_study(scene);
  EXPECT_EQ(study.sweeps[0].values.back(), 0.3);
  EXPECT_EQ(study.sweeps[1].values.back(), 0.7);
  EXPECT_EQ(study.sweeps[0].values.front(), 0.1);
  EXPECT_EQ(study.sweeps[1].values.front(), 0.3);
}

// Rank 1 of 2 whose rank 0 reports a failed validation: the broadcast verdict.
class RankOneOfTwo : public StudyCommunicator {
 public:
  explicit RankOneOfTwo(std::string verdict) : verdict_(std::move(verdict)) {}
  int rank() const override { return 1; }
  int size() const override { return 2; }
  std::vector<std::string> gather(const std::string&) override {
    ++gathers;
    return {};
  }
  std::string broadcast(const std::string&) override {
    ++broadcasts;
    return verdict_;
  }
  int gathers = 0, broadcasts = 0;

 private:
  std::string verdict_;
};

TEST(StudyRun, ARankStopsWhenAnotherCouldNotValidate) {
  // This rank validates the study; rank 0 did not (exit code 2): it returns that code
  // before computing anything, instead of waiting for collectives rank 0 never enters.
  TempDir dir;
  const auto file = quickstart_with_study(
      dir, "study:\n  sweep:\n    - {path: contacts.root_friction.params.kt, values: [1e5]}\n");
  RankOneOfTwo rank_one(std::to_string(kExitInvalidInput));
  EXPECT_EQ(study_into(file, dir.path() / "out", 1, rank_one), kExitInvalidInput);
  EXPECT_FALSE(fs::exists(dir.path() / "out"));
  // One collective pair, the verdict; no staging folder broadcast, no outcomes gathered.
  EXPECT_EQ(rank_one.gathers, 1);
  EXPECT_EQ(rank_one.broadcasts, 1);
}

TEST(Output, JsonWithTextThatIsNotUtf8IsWritten) {
  // A message quoting a Latin-1 file name: written with a replacement character instead of
  // throwing (nlohmann::json refuses invalid UTF-8 by default).
  TempDir dir;
  const nlohmann::json doc = {{"message", std::string("cannot read caf\xe9.yaml")}};
  ASSERT_NO_THROW(write_json(dir.path() / "summary.json", doc));
  const auto text = read_text(dir.path() / "summary.json");
  EXPECT_THAT(text, HasSubstr("cannot read caf\xef\xbf\xbd.yaml"));
  EXPECT_EQ(nlohmann::json::parse(text).at("message").get<std::string>(),
            "cannot read caf\xef\xbf\xbd.yaml");
}

// The convergence verb as a library caller runs it into a folder: the folder staged once the
// request is valid, each setting's run written into runs/, the report written and committed.
ConvergenceResult convergence_into(ConvergenceRequest request, const fs::path& folder) {
  std::optional<StagedOutput> out;
  request.stage_runs = [&] {
    out.emplace(folder, convergence_outputs());
    return out->path("runs");
  };
  request.write_run = write_run_folder;
  ConvergenceResult result = study_convergence(request);
  write_convergence(result, *out);
  out->commit();
  return result;
}

// The convergence report: errors against the finest setting shrink with more harmonics, and
// the finest setting agrees with the independent time integration.
TEST(Convergence, ErrorsShrinkAndTheFinestAgreesWithTimeIntegration) {
  TempDir dir;
  const auto scene = quickstart_with_study(dir, "");
  ConvergenceRequest request;
  request.scene.file = scene;
  request.harmonics = {1, 3, 7};
  request.samples = {64, 256};
  request.oversampling = {1, 4};
  const ConvergenceResult result = convergence_into(request, dir.path() / "conv");
  ASSERT_EQ(result.outcome.status, kExitOk);
  // The result in memory.
  ASSERT_EQ(result.rows.size(), 12u);  // 3 x 2 x 2, every N >= 2H + 1
  EXPECT_EQ(result.rows.back().setting.id, "H7_N256_o4");
  EXPECT_EQ(result.rows.back().amplitude_error, 0.0);
  std::map<std::string, const ConvergenceRow*> rows_by_id;
  for (const auto& r : result.rows) rows_by_id[r.setting.id] = &r;
  EXPECT_GT(rows_by_id.at("H1_N256_o4")->amplitude_error,
            3 * rows_by_id.at("H3_N256_o4")->amplitude_error);
  EXPECT_TRUE(result.timesim.run && result.timesim.periodic);
  // The report written from it.
  const auto report = nlohmann::json::parse(read_text(dir.path() / "conv" / "convergence.json"));
  EXPECT_EQ(report["reference"], "H7_N256_o4");
  const auto& settings = report["settings"];
  ASSERT_EQ(settings.size(), 12u);
  std::map<std::string, nlohmann::json> by_id;
  for (const auto& s : settings) by_id[s["setting"].get<std::string>()] = s;
  EXPECT_EQ(by_id["H7_N256_o4"]["amplitude_error"], 0.0);
  // The single-harmonic peak is off by more than the three-harmonic one (thesis §5.1: more
  // harmonics are needed near stick-slip).
  EXPECT_GT(by_id["H1_N256_o4"]["amplitude_error"].get<double>(),
            3 * by_id["H3_N256_o4"]["amplitude_error"].get<double>());
  // Unknowns: 2H + 1 coefficients of one contact component (harmonic 0 kept).
  EXPECT_EQ(by_id["H3_N64_o1"]["unknowns"], 7);
  // Time integration at the reference peak frequency, an independent oracle.
  ASSERT_TRUE(report["time_integration"].is_object());
  EXPECT_TRUE(report["time_integration"]["periodic"].get<bool>());
  EXPECT_LT(by_id["H7_N256_o4"]["amplitude_error_vs_timesim"].get<double>(), 1e-4);
  const auto rows = read_csv(dir.path() / "conv" / "convergence.csv");
  ASSERT_EQ(rows.size(), 13u);
  EXPECT_EQ(rows[0].back(), "wall_s");
  EXPECT_TRUE(fs::exists(dir.path() / "conv" / "runs" / "H1_N64_o1" / "response.csv"));
}

TEST(Convergence, ImpossibleFinestSettingIsRefused) {
  TempDir dir;
  ConvergenceRequest request;
  request.scene.file = quickstart_with_study(dir, "");
  request.harmonics = {40};
  request.samples = {64};  // < 2 * 40 + 1
  EXPECT_THROW(study_convergence(request), SceneError);
}

}  // namespace
