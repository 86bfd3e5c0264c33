// frichb-conformance: runs the contact-law conformance kit on one plugin library.
//   frichb-conformance LIB.so [--params "{kt: 1e5, mu: 0.3, normal_load: 10}"] [...]
// Prints each check with its figure; exits 0 when none failed, 1 otherwise, 2 on bad usage.
#include <boost/program_options.hpp>
#include <iostream>

#include "frichb/conformance/contact_law_checks.hpp"

namespace po = boost::program_options;

int main(int argc, char** argv) {
  frichb::conformance::ContactLawOptions options;
  std::string library;
  po::options_description opts(
      "frichb-conformance LIB.so [options]: checks a contact-law plugin through the real "
      "loader\n(tangents vs central differences, Coulomb bound, dissipation, periodicity, "
      "separation,\nmu = 0, full stick, symmetry, frame invariance, determinism, schema, order)"
      "\n\nOptions");
  opts.add_options()("help,h", "show this help")(
      "params", po::value<std::string>(&options.params_yaml)->default_value("{}"),
      "the law's parameters as a YAML map")(
      "amplitude", po::value<double>(&options.amplitude)->default_value(0.0),
      "amplitude of the test motions in m (0: 5 mu N / kt, else 1e-3)")(
      "seed", po::value<unsigned>(&options.seed)->default_value(1), "random motion seed")(
      "samples", po::value<int>(&options.samples_per_period)->default_value(256),
      "samples per period")("harmonics", po::value<int>(&options.max_harmonic)->default_value(5),
                            "harmonics 0..H of the test motions")(
      "tolerance", po::value<double>(&options.jacobian_tolerance)->default_value(1e-6),
      "relative tolerance of tangents vs central differences")(
      "per-component-bound", po::bool_switch(&options.per_component_bound),
      "Coulomb bound per tangential component (independent directions)")(
      "order", po::value<double>(&options.order)->default_value(0.0),
      "order in the sample spacing the law declares for its force harmonics, checked from "
      "samples/4 to samples against 8 x samples (0: not checked)");
  po::options_description hidden;
  hidden.add_options()("library", po::value<std::string>(&library));
  po::options_description all;
  all.add(opts).add(hidden);
  po::positional_options_description positional;
  positional.add("library", 1);
  po::variables_map vm;
  try {
    po::store(po::command_line_parser(argc, argv).options(all).positional(positional).run(), vm);
    po::notify(vm);
  } catch (const std::exception& e) {
    std::cerr << "frichb-conformance: " << e.what() << "\n" << opts << "\n";
    return 2;
  }
  if (vm.count("help") || library.empty()) {
    std::cout << opts << "\n";
    return vm.count("help") ? 0 : 2;
  }
  const auto report = frichb::conformance::check_contact_law(library, options);
  std::cout << frichb::conformance::format_report(report);
  return report.passed() ? 0 : 1;
}
