// `validate` means `run` will start: a corpus of bad scenes, each the quick-start scene or the
// FE-sector example with one thing wrong (in the scene or in a file it names), goes through
// both verbs of the real program. Both must refuse it with exit code 2 and the same error
// message, naming the file (and line:column where the value came from a scene line), and
// `run` must write nothing. A scene without contacts is not bad: both verbs accept it and
// `run` gives the linear response.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
void write_text(const fs::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary) << text;
}
std::string replace_once(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos || text.find(from, at + 1) != std::string::npos)
    throw std::runtime_error("'" + from + "' does not occur exactly once");
  return text.replace(at, from.size(), to);
}
std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct Result {
  int code = -1;
  std::string output;
};
Result frichb(const std::string& args) {
  const std::string command = shell_quoted(FRICHB_EXE) + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) throw std::runtime_error("popen failed");
  Result r;
  std::array<char, 4096> buffer{};
  std::size_t n = 0;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0)
    r.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  r.code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
  return r;
}

// The error lines of a log, without their time stamps.
std::vector<std::string> errors(const std::string& log) {
  std::vector<std::string> out;
  std::istringstream lines(log);
  std::string line;
  while (std::getline(lines, line)) {
    const auto at = line.find("[error] ");
    if (at != std::string::npos) out.push_back(line.substr(at + 8));
  }
  return out;
}

// One bad input: a name, a change of the scene text, and (for FE scenes) of the matrix files
// in the scene's folder; `expect` is a piece of the message.
struct BadScene {
  std::string name;
  bool fe = false;
  std::function<std::string(std::string)> scene;
  std::function<void(const fs::path& folder)> files;
  std::string expect;
  bool located = true;  // the message carries file:line:column
};

std::function<std::string(std::string)> swap(std::string from, std::string to) {
  return [from = std::move(from), to = std::move(to)](std::string text) {
    return replace_once(std::move(text), from, to);
  };
}
// Replaces line `line` (1-based) of a file.
void edit_line(const fs::path& file, int line, const std::string& text) {
  std::istringstream in(read_text(file));
  std::ostringstream out;
  std::string l;
  for (int i = 1; std::getline(in, l); ++i) out << (i == line ? text : l) << "\n";
  write_text(file, out.str());
}

// A lumped cyclic disk of `sectors` sectors under engine order 2 (engine order 1 from 1000
// sectors on) with friction shrouds and output.stability, traced on `samples` samples.
std::string cyclic_stability_scene(int sectors, int samples) {
  std::ostringstream s;
  s << "cyclic: {sectors: " << sectors << ", engine_order: " << (sectors >= 1000 ? 1 : 2)
    << "}\nstructure:\n  provider: lumped_cyclic\n  params:\n    sectors: " << sectors
    << "\n    masses: [0.5, 0.1]\n"
    << "    springs: [{between: [ground, 0], k: 2.0e6}, {between: [0, 1], k: 4.0e5}]\n"
    << "    coupling: [{between: [0, 0], k: 1.0e5}]\n    modal_damping: [0.01]\n"
    << "  dofs: {disk: 0, blade: 1}\nexcitation: [{dof: blade, amplitude: 2.0}]\ncontacts:\n"
    << "  - name: shroud\n    law: jenkins_1d\n"
    << "    between: [{node: blade, sector: 0}, {node: blade, sector: 1}]\n"
    << "    params: {kt: 1.0e5, mu: 0.5, normal_load: 5.0}\n"
    << "harmonic_balance: {harmonics: [0, 1, 2, 3], samples_per_period: " << samples << "}\n"
    << "continuation: {frequency: {from: 200, to: 400}}\n"
    << "output: {response: [blade], stability: true}\n";
  return s.str();
}

std::vector<BadScene> corpus() {
  const std::string lumped_springs = "      - {between: [ground, 0], k: 4.0e5}";
  std::vector<BadScene> c = {
      // The structure provider refuses its parameters (run used to find these alone).
      {"spring_end_beyond_the_dofs",
       false,
       swap(lumped_springs, "      - {between: [ground, 3], k: 4.0e5}"),
       {},
       "structure.params: structure 'lumped' refused its parameters: end '3'"},
      {"negative_mass", false, swap("masses: [0.1]", "masses: [-0.1]"), {}, "structure.params"},
      {"modal_damping_count",
       false,
       swap("modal_damping: [0.005]", "modal_damping: [0.005, 0.01]"),
       {},
       "structure.params.modal_damping: "},
      {"dof_index_out_of_range",
       false,
       swap("dofs: {blade: 0}", "dofs: {blade: 4}"),
       {},
       "structure.dofs.blade: DOF 4 does not exist"},
      {"cyclic_section_on_a_plain_structure",
       false,
       swap("\nstructure:", "\ncyclic: {sectors: 8, engine_order: 1}\nstructure:"),
       {},
       "cyclic: the scene has cyclic.sectors = 8"},
      {"law_refuses_its_parameters",
       false,
       swap("{kt: 2.0e5, mu: 0.5, normal_load: 5.0}", "{kt: 2.0e5, mu: 0.5, normal_load: -5.0}"),
       {},
       "contacts[0].params"},
      {"rigid_body_with_a_static_harmonic",
       false,
       [lumped_springs](std::string t) {
         t = replace_once(t, lumped_springs + "\n", "");
         t = replace_once(t, "    springs:\n", "");
         return replace_once(t, "  max_harmonic: 7", "  harmonics: [0, 1]");
       },
       {},
       "the structure has a rigid-body mode"},
      {"more_unknowns_than_memory",
       false,
       [](std::string t) {
         t = replace_once(t, "  max_harmonic: 7", "  max_harmonic: 60000");
         return replace_once(t, "  samples_per_period: 128", "  samples_per_period: 131072");
       },
       {},
       "harmonic_balance: "},
      // The stability of a cyclic scene: its sector delays must be whole samples, and its
      // whole disk (1200 sectors here: 7200 unknowns) must fit the dense monodromy.
      {"cyclic_stability_sector_delays_of_fractional_samples",
       false,
       [](const std::string&) { return cyclic_stability_scene(6, 100); },
       {},
       "output.stability: the stability of a cyclic scene needs"},
      {"cyclic_stability_whole_disk_too_large",
       false,
       [](const std::string&) { return cyclic_stability_scene(1200, 1200); },
       {},
       "output.stability: the stability of this cyclic scene integrates the whole disk: 7200 "
       "unknowns"},
      // Scene-level errors (both verbs found these before; kept in the corpus).
      {"unknown_law", false, swap("law: jenkins_1d", "law: jenkins_2d"), {}, "unknown plugin"},
      {"unknown_provider",
       false,
       swap("provider: lumped", "provider: lumpy"),
       {},
       "unknown plugin"},
      {"excitation_of_an_unknown_dof",
       false,
       swap("- {dof: blade,", "- {dof: blades,"),
       {},
       "excitation[0].dof"},
      {"excited_harmonic_not_kept",
       false,
       swap("amplitude: 2.0, harmonic: 1}", "amplitude: 2.0, harmonic: 9}"),
       {},
       "is not among harmonic_balance's kept harmonics"},
      {"samples_below_nyquist",
       false,
       swap("samples_per_period: 128", "samples_per_period: 8"),
       {},
       "aliasing"},
      {"sweep_of_zero_width",
       false,
       swap("{from: 250, to: 450, unit: Hz}", "{from: 250, to: 250, unit: Hz}"),
       {},
       "from equals to"},
      {"steps_out_of_order",
       false,
       swap("step: {initial: 1.0, min: 1.0e-5, max: 2.0}",
            "step: {initial: 1.0, min: 3.0, max: 2.0}"),
       {},
       "min <= initial <= max"},
      {"response_of_an_unknown_node",
       false,
       swap("response: [blade]", "response: [tip]"),
       {},
       "output.response[0]"},
      {"contact_on_one_node_twice",
       false,
       swap("between: [ground, blade]", "between: [blade, blade]"),
       {},
       "both sides are the same node"},
      {"contact_name_with_a_slash",
       false,
       swap("name: root_friction", "name: root/friction"),
       {},
       "contacts[0].name"},
      // A '.' splits a --set path (contacts.root.friction.params.kt cannot reach it); a name
      // of digits is a list index there (contacts.1 is the second contact).
      {"contact_name_with_a_dot",
       false,
       swap("name: root_friction", "name: root.friction"),
       {},
       "contacts[0].name: 'root.friction': use letters, digits, '_' and '-'"},
      // A name holding a terminal escape sequence: quoted escaped, never sent to the terminal.
      {"contact_name_with_a_terminal_escape",
       false,
       swap("name: root_friction", "name: \"root\\e[2Jfriction\""),
       {},
       "'root\\x1B[2Jfriction': use letters"},
      {"contact_name_of_digits",
       false,
       swap("name: root_friction", "name: \"1\""),
       {},
       "a name of digits alone is read as a list index by --set"},
      {"dof_name_with_a_dot",
       false,
       swap("dofs: {blade: 0}", "dofs: {bla.de: 0}"),
       {},
       "structure.dofs.bla.de: 'bla.de': use letters, digits"},
      // ${name} unquoted in a flow map: YAML reads its braces before any substitution.
      {"variable_unquoted_in_a_flow_map",
       false,
       [](std::string t) {
         return "variables: {k: 2.0e5}\n" +
                replace_once(std::move(t), "params: {kt: 2.0e5,", "params: {kt: ${k},");
       },
       {},
       "must be quoted: \"${name}\""},
      {"dof_name_with_a_comma",
       false,
       swap("dofs: {blade: 0}", "dofs: {\"bla,de\": 0}"),
       {},
       "use letters, digits"},
      {"duplicate_key",
       false,
       swap("  max_harmonic: 7", "  max_harmonic: 7\n  max_harmonic: 3"),
       {},
       "duplicate key 'max_harmonic'"},
      {"duplicate_section",
       false,
       [](std::string t) { return t + "\noutput: {plots: false}\n"; },
       {},
       "duplicate key 'output'"},
      {"duplicate_dof_name",
       false,
       swap("dofs: {blade: 0}", "dofs: {blade: 0, blade: 0}"),
       {},
       "duplicate key 'blade'"},
      {"second_document",
       false,
       [](std::string t) { return t + "---\nname: x\n"; },
       {},
       "a second YAML document"},
      {"unclosed_quote",
       false,
       swap("name: friction_oscillator", "name: \"friction_oscillator"),
       {},
       "is never closed"},
      {"plugin_path_missing",
       false,
       swap("\nname: friction_oscillator", "\nname: friction_oscillator\nplugin_paths: [nowhere]"),
       {},
       "plugin_paths[0]: folder"},
      {"alias_cycle",
       false,
       [](std::string t) { return t + "\nanchors: &a [*a]\n"; },
       {},
       "nests deeper than 64 levels"},
      {"alias_fan_out",
       false,
       [](std::string t) {
         t += "\na0: &a0 [1, 1, 1, 1, 1, 1, 1, 1]\n";
         for (int i = 1; i < 10; ++i) {
           t += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [";
           for (int k = 0; k < 8; ++k) t += (k ? ", *a" : "*a") + std::to_string(i - 1);
           t += "]\n";
         }
         return t;
       },
       {},
       "more than a million nodes"},
      {"malformed_yaml", false, swap("masses: [0.1]", "masses: [0.1"), {}, "malformed YAML"},
      {"wrong_type", false, swap("mu: 0.5", "mu: lots"), {}, "contacts[0].params.mu"},
      {"unknown_key",
       false,
       swap("  target_newton_iterations: 4", "  target_newton_iteration: 4"),
       {},
       "target_newton_iteration"},
      {"missing_structure",
       false,
       [](std::string t) {
         const auto a = t.find("\nstructure:");
         const auto b = t.find("\nexcitation:");
         return t.erase(a, b - a);
       },
       {},
       "structure: missing required section"},
      // FE sector: errors in the matrix files and the provider's parameters.
      {"mass_file_missing",
       true,
       swap("models/generated/sector_mass.mtx", "models/generated/none.mtx"),
       {},
       "structure.params.mass"},
      {"mass_file_not_matrix_market",
       true,
       {},
       [](const fs::path& f) {
         edit_line(f / "models/generated/sector_mass.mtx", 1, "%%NotMarket");
       },
       "not a Matrix Market file"},
      {"mass_file_truncated",
       true,
       {},
       [](const fs::path& f) {
         std::string t = read_text(f / "models/generated/sector_mass.mtx");
         write_text(f / "models/generated/sector_mass.mtx",
                    t.substr(0, t.rfind('\n', t.size() - 2) + 1));
       },
       "the file ends after"},
      {"mass_entry_not_a_number",
       true,
       {},
       [](const fs::path& f) { edit_line(f / "models/generated/sector_mass.mtx", 5, "2 2 nan"); },
       "expected a finite number"},
      {"mass_entry_infinite",
       true,
       {},
       [](const fs::path& f) { edit_line(f / "models/generated/sector_mass.mtx", 5, "2 2 inf"); },
       "expected a finite number"},
      {"mass_index_out_of_range",
       true,
       {},
       [](const fs::path& f) { edit_line(f / "models/generated/sector_mass.mtx", 5, "99 2 0.2"); },
       "outside [1, "},
      {"stiffness_not_symmetric",
       true,
       {},
       [](const fs::path& f) {
         const fs::path k = f / "models/generated/sector_stiffness.mtx";
         std::string t = read_text(k);
         t = replace_once(t, "real symmetric", "real general");
         write_text(k, t);
       },
       "is not symmetric"},
      {"mass_indefinite",
       true,
       {},
       [](const fs::path& f) { edit_line(f / "models/generated/sector_mass.mtx", 5, "2 2 -0.2"); },
       "is not positive definite"},
      {"mass_and_stiffness_of_different_sizes",
       true,
       {},
       [](const fs::path& f) {
         const fs::path m = f / "models/generated/sector_mass.mtx";
         std::string t = read_text(m);
         t = replace_once(t, "\n23 23 23\n", "\n24 24 24\n");
         write_text(m, t + "24 24 0.1\n");
       },
       "DOFs but the stiffness matrix"},
      {"boundary_lists_of_different_lengths",
       true,
       swap("right_dofs: [4, 9, 14, 19]", "right_dofs: [4, 9, 14]"),
       {},
       "structure.params"},
      {"boundary_dof_out_of_range",
       true,
       swap("right_dofs: [4, 9, 14, 19]", "right_dofs: [4, 9, 14, 99]"),
       {},
       "structure.params"},
      {"more_modes_than_dofs",
       true,
       swap("modes: 10", "modes: 100"),
       {},
       "structure.params.modes: structure 'fe_sector' refused its parameters: modes = 100 exceeds"},
      {"modal_damping_of_another_count",
       true,
       swap("modal_damping: [0.005]", "modal_damping: [0.005, 0.01, 0.02]"),
       {},
       "structure.params.modal_damping: "},
      {"sector_counts_differ",
       true,
       swap("cyclic: {sectors: 8,", "cyclic: {sectors: 6,"),
       {},
       "cyclic: the scene has cyclic.sectors = 6"},
      {"fe_dof_out_of_range",
       true,
       swap("dofs: {tip: 22, root: 20}", "dofs: {tip: 23, root: 20}"),
       {},
       "structure.dofs.tip: DOF 23 does not exist"},
      {"cyclic_pairs_file_missing",
       true,
       swap("    left_dofs: [0, 5, 10, 15]\n    right_dofs: [4, 9, 14, 19]\n",
            "    cyclic_pairs: models/generated/pairs.txt\n"),
       {},
       "structure.params.cyclic_pairs"},
      {"both_boundary_forms",
       true,
       swap("    left_dofs: [0, 5, 10, 15]\n",
            "    left_dofs: [0, 5, 10, 15]\n    cyclic_pairs: models/generated/sector_mass.mtx\n"),
       {},
       "structure.params"},
      {"neighbour_sector_without_cyclic",
       false,
       swap("between: [ground, blade]", "between: [ground, {node: blade, sector: 1}]"),
       {},
       "needs a `cyclic: {sectors, engine_order}` section"},
  };
  return c;
}

class ValidateCorpus : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("frichb_corpus_" + std::to_string(getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    quickstart_ =
        read_text(fs::path(FRICHB_SOURCE_DIR) / "configs" / "quickstart_friction_oscillator.yaml");
    fe_scene_ = read_text(fs::path(FRICHB_SOURCE_DIR) / "configs" / "fe_sector_example.yaml");
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  // A fresh folder with the scene (and for FE scenes freshly generated matrices).
  fs::path prepare(const BadScene& bad) {
    const fs::path folder = dir_ / bad.name;
    fs::create_directories(folder);
    if (bad.fe) {
      const int rc =
          std::system(("python3 " +
                       shell_quoted((fs::path(FRICHB_SOURCE_DIR) / "configs" / "models" /
                                     "make_example_sector.py")
                                        .string()) +
                       " " + shell_quoted((folder / "models/generated").string()) + " > /dev/null")
                          .c_str());
      if (rc != 0) throw std::runtime_error("make_example_sector.py failed");
    }
    std::string text = bad.fe ? fe_scene_ : quickstart_;
    if (bad.scene) text = bad.scene(text);
    if (bad.files) bad.files(folder);
    write_text(folder / "scene.yaml", text);
    return folder / "scene.yaml";
  }
  fs::path dir_;
  std::string quickstart_, fe_scene_;
};

TEST_F(ValidateCorpus, EveryBadSceneIsRefusedAlikeByValidateAndRun) {
  const auto bad_scenes = corpus();
  EXPECT_GE(bad_scenes.size(), 40u);
  const std::regex location(R"(:[0-9]+:[0-9]+: )");
  for (const auto& bad : bad_scenes) {
    SCOPED_TRACE(bad.name);
    const fs::path scene = prepare(bad);
    const fs::path out = scene.parent_path() / "out";
    const Result v = frichb("--log-level warn validate " + shell_quoted(scene.string()));
    const Result r = frichb("--log-level warn run " + shell_quoted(scene.string()) + " -o " +
                            shell_quoted(out.string()));
    EXPECT_EQ(v.code, 2) << v.output;
    EXPECT_EQ(r.code, 2) << r.output;
    const auto ve = errors(v.output), re = errors(r.output);
    ASSERT_EQ(ve.size(), 1u) << v.output;
    EXPECT_EQ(ve, re) << "validate:\n" << v.output << "run:\n" << r.output;
    EXPECT_THAT(ve.front(), HasSubstr(bad.expect));
    EXPECT_THAT(ve.front(), HasSubstr(scene.string()));
    if (bad.located) {
      EXPECT_TRUE(std::regex_search(ve.front(), location)) << ve.front();
    }
    EXPECT_FALSE(fs::exists(out)) << "run wrote an output folder for a refused scene";
    for (const auto& entry : fs::directory_iterator(scene.parent_path())) {
      const std::string name = entry.path().filename().string();
      EXPECT_TRUE(name == "scene.yaml" || name == "models") << "left behind: " << name;
    }
  }
}

// No contacts: the linear response, from both verbs.
TEST_F(ValidateCorpus, ASceneWithoutContactsIsTheLinearResponse) {
  BadScene none{"no_contacts",
                false,
                [](std::string t) {
                  const auto a = t.find("\ncontacts:");
                  const auto b = t.find("\nharmonic_balance:");
                  t.replace(a, b - a, "\ncontacts: []\n");
                  return replace_once(t, "  friction_loops_at: [330.0, 400.0]\n", "");
                },
                {},
                ""};
  const fs::path scene = prepare(none);
  const Result v = frichb("validate " + shell_quoted(scene.string()));
  EXPECT_EQ(v.code, 0) << v.output;
  const fs::path out = scene.parent_path() / "out";
  const Result r =
      frichb("run " + shell_quoted(scene.string()) + " -o " + shell_quoted(out.string()));
  ASSERT_EQ(r.code, 0) << r.output;
  // 1 DOF, m = 0.1 kg, k = 4e5 N/m, modal damping 0.005, F = 2 N: |x| = F / |k - m w^2 + i c w|
  // with c = 2 zeta sqrt(k m), at every point of response.csv.
  std::istringstream csv(read_text(out / "response.csv"));
  std::string line;
  std::getline(csv, line);
  int rows = 0;
  while (std::getline(csv, line)) {
    std::vector<double> cols;
    std::stringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) cols.push_back(std::stod(cell));
    const double w = cols[2], k = 4e5, m = 0.1, c = 2 * 0.005 * std::sqrt(k * m);
    const double exact = 2.0 / std::hypot(k - m * w * w, c * w);
    EXPECT_NEAR(cols[5], exact, 1e-9 * exact) << line;  // blade_h1_m
    // blade_amplitude_m: the largest of 1024 time samples of the period, within 1 - cos(pi/1024)
    EXPECT_NEAR(cols[3], exact, 5e-6 * exact) << line;
    ++rows;
  }
  EXPECT_GT(rows, 10);
}

}  // namespace
