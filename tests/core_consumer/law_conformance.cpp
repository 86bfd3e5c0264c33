// Runs the installed conformance kit on a contact-law plugin from C++:
// law_conformance LAW.so "{params}" prints the report and fails when a check fails.
#include <cstdio>

#include "frichb/conformance/contact_law_checks.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: law_conformance LAW.so \"{params}\"\n");
    return 2;
  }
  frichb::conformance::ContactLawOptions options;
  options.params_yaml = argv[2];
  const auto report = frichb::conformance::check_contact_law(argv[1], options);
  std::printf("%s", frichb::conformance::format_report(report).c_str());
  return report.passed() && report.count(frichb::conformance::CheckStatus::kPassed) > 0 ? 0 : 1;
}
