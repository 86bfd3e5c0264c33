// The conformance kit itself: shipped laws pass, deliberately faulty laws fail the check
// that names their fault, and a law without tangents has its tangent check skipped.
#include "frichb/conformance/contact_law_checks.hpp"

#include <gtest/gtest.h>

#include <string>

namespace frichb::conformance {
namespace {

const std::string kPlugins = FRICHB_PLUGIN_DIR;
const std::string kTestPlugins = FRICHB_TEST_PLUGIN_DIR;

ContactLawOptions jenkins_params() {
  ContactLawOptions o;
  o.params_yaml = "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}";
  return o;
}

CheckStatus status_of(const ContactLawReport& r, const std::string& name) {
  const CheckResult* c = r.find(name);
  EXPECT_NE(c, nullptr) << name;
  return c ? c->status : CheckStatus::kSkipped;
}

TEST(Conformance, JenkinsPassesEveryCheck) {
  const auto r = check_contact_law(kPlugins + "/frichb_jenkins_1d.so", jenkins_params());
  EXPECT_TRUE(r.passed()) << format_report(r);
  EXPECT_EQ(status_of(r, "tangent_vs_central_differences"), CheckStatus::kPassed);
  EXPECT_EQ(status_of(r, "coulomb_bound"), CheckStatus::kPassed);
  EXPECT_GE(r.count(CheckStatus::kPassed), 9);
}

TEST(Conformance, ASignErrorInTheTangentFailsTheTangentCheck) {
  const auto r =
      check_contact_law(kTestPlugins + "/frichb_test_faulty_tangent_sign.so", jenkins_params());
  EXPECT_FALSE(r.passed());
  EXPECT_EQ(status_of(r, "tangent_vs_central_differences"), CheckStatus::kFailed)
      << format_report(r);
  // The values are right: only the tangent check may fail.
  EXPECT_EQ(r.count(CheckStatus::kFailed), 1) << format_report(r);
}

TEST(Conformance, AForceBeyondTheCoulombBoundFailsTheBoundCheck) {
  const auto r =
      check_contact_law(kTestPlugins + "/frichb_test_faulty_beyond_coulomb.so", jenkins_params());
  EXPECT_EQ(status_of(r, "coulomb_bound"), CheckStatus::kFailed) << format_report(r);
  EXPECT_NE(r.find("coulomb_bound")->figure.find("1.5"), std::string::npos);
}

TEST(Conformance, ALawWithoutTangentsSkipsTheTangentCheck) {
  ContactLawOptions o;
  o.params_yaml = "{kt: 2.0e5, slip_force: 2.5}";
  const auto r = check_contact_law(kTestPlugins + "/frichb_test_tangentless.so", o);
  EXPECT_TRUE(r.passed()) << format_report(r);
  EXPECT_EQ(status_of(r, "tangent_vs_central_differences"), CheckStatus::kSkipped);
}

TEST(Conformance, MissingRequiredParametersAreReported) {
  const auto r = check_contact_law(kPlugins + "/frichb_jenkins_1d.so", ContactLawOptions{});
  EXPECT_FALSE(r.passed());
  EXPECT_EQ(status_of(r, "given_parameters_validate"), CheckStatus::kFailed);
}

TEST(Conformance, AStructurePluginIsRefused) {
  const auto r = check_contact_law(kPlugins + "/frichb_lumped.so", ContactLawOptions{});
  EXPECT_EQ(status_of(r, "is_a_contact_law"), CheckStatus::kFailed);
}

}  // namespace
}  // namespace frichb::conformance
