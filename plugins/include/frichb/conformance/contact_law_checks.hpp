// The contact-law conformance kit: checks any contact-law plugin through the real loader.
//
// Every shipped law passes it (ctest), and a third party runs it on their own library with
// the `frichb-conformance LIB.so` runner or, in CMake, frichb_add_conformance_test(). The
// checks follow docs/plugin-authoring.md: tangents against central differences away from
// kinks, value-only equals value-with-tangent, separation gives zero force and tangent,
// N >= 0, |T| <= mu N, dissipation >= 0, periodicity, mu = 0 gives T = 0, full stick is the
// linear spring, odd symmetry, frame invariance (2D tangential laws), determinism across
// repeats and threads, and schema manners (given parameters validate, out-of-range values
// are refused).
//
// Checks that need to know a law's physics read parameters by conventional names: `mu`
// (friction coefficient), `kt` (tangential stiffness), `normal_load` (preload or constant
// normal load). A law without such a parameter gets those checks as "skipped", with the
// reason. Not thread-safe per call (it starts its own threads for the thread check).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace frichb::conformance {

enum class CheckStatus { kPassed, kFailed, kSkipped };

struct CheckResult {
  std::string name;  // e.g. "tangent_vs_central_differences"
  CheckStatus status = CheckStatus::kSkipped;
  std::string figure;  // the measured figure, e.g. "max relative error 3.1e-09 (212 steps)"
};

struct ContactLawOptions {
  // The law's parameters as a YAML map, e.g. "{kt: 1.0e5, mu: 0.3, normal_load: 10}".
  // Required parameters must be given; defaults fill the rest.
  std::string params_yaml = "{}";
  // Amplitude of the random test motions, m. 0: 5 mu N / kt when the law has those
  // parameters (deep slip), else 1e-3.
  double amplitude = 0.0;
  unsigned seed = 1;
  int samples_per_period = 256;
  int max_harmonic = 5;
  double jacobian_tolerance = 1e-6;  // relative to the largest tangent entry
  // The Coulomb bound per tangential component (|T_i| <= mu N) instead of on the norm
  // (|T| <= mu N): for laws whose directions slide independently (uncoupled_2d). Frame
  // invariance is then not expected and skipped.
  bool per_component_bound = false;
  // The order in the sample spacing that the law declares for its force harmonics (0: not
  // checked). The check traces the test motion on samples_per_period / 4, / 2 and x 1 samples
  // against a trace on 8 x samples_per_period and requires the fitted slope to reach it
  // (less 0.25).
  double order = 0.0;
};

struct ContactLawReport {
  std::string plugin_name;
  std::filesystem::path file;
  std::vector<CheckResult> checks;
  int count(CheckStatus s) const;
  bool passed() const { return count(CheckStatus::kFailed) == 0; }
  const CheckResult* find(const std::string& name) const;
};

// Loads `plugin_file` (which must be a contact law) and runs every check. A plugin that
// cannot be loaded or refuses the parameters gives a report with one failed check saying why.
ContactLawReport check_contact_law(const std::filesystem::path& plugin_file,
                                   const ContactLawOptions& options);

// One line per check ("PASS name  figure"), then "N passed, N failed, N skipped".
std::string format_report(const ContactLawReport& report);

}  // namespace frichb::conformance
