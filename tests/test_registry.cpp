// Plugin discovery and loading through the real loader (Boost.DLL), and validation of scene
// parameters against a plugin's schema.
//
// Needs the built plugins: frichb_jenkins_1d and frichb_lumped in FRICHB_PLUGIN_DIR, and the
// test-only plugins of tests/plugins (target frichb_test_plugins) in FRICHB_TEST_PLUGIN_DIR.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <boost/dll/shared_library.hpp>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"

namespace {

namespace fs = std::filesystem;
using frichb::core::ContactLawInstance;
using frichb::core::load_plugin_file;
using frichb::core::PluginError;
using frichb::core::Registry;
using frichb::core::SceneError;
using frichb::core::validate_params;
using frichb::core::YamlContext;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Not;

const fs::path kPluginDir = FRICHB_PLUGIN_DIR;
const fs::path kTestPluginDir = FRICHB_TEST_PLUGIN_DIR;
const fs::path kWrongAbiFile = kTestPluginDir / "frichb_test_wrong_abi.so";
const fs::path kDupA = kTestPluginDir / "dup_a";
const fs::path kDupB = kTestPluginDir / "dup_b";

// Runs `fn`, expecting it to throw E; returns what() ("" and a failure when it does not).
template <class E, class Fn>
std::string message_of(Fn&& fn) {
  try {
    fn();
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << "no exception of the expected type was thrown";
  return "";
}

std::vector<std::string> schema_names(std::span<const frichb_param_spec> schema) {
  std::vector<std::string> names;
  for (const auto& s : schema) names.emplace_back(s.name);
  return names;
}

// ---------------------------------------------------------------------------------------
// Discovery and loading
// ---------------------------------------------------------------------------------------

TEST(Registry, ListsBuiltInPluginsFromSymbolTables) {
  ASSERT_TRUE(fs::is_regular_file(kPluginDir / "frichb_jenkins_1d.so")) << kPluginDir;
  ASSERT_TRUE(fs::is_regular_file(kPluginDir / "frichb_lumped.so")) << kPluginDir;
  const Registry registry({kPluginDir});
  const auto names = registry.names();
  EXPECT_THAT(names, Contains("jenkins_1d"));
  EXPECT_THAT(names, Contains("lumped"));
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
  EXPECT_TRUE(registry.contains("jenkins_1d"));
  EXPECT_FALSE(registry.contains("jenkins"));
  EXPECT_EQ(registry.file_of("jenkins_1d").filename(), "frichb_jenkins_1d.so");
  EXPECT_EQ(registry.file_of("lumped").filename(), "frichb_lumped.so");
  EXPECT_TRUE(registry.file_of("no_such_plugin").empty());
}

TEST(Registry, MissingFoldersOnTheSearchPathAreSkipped) {
  const Registry registry({kPluginDir / "no_such_folder", kPluginDir});
  EXPECT_THAT(registry.names(), Contains("jenkins_1d"));
  const Registry empty({kPluginDir / "no_such_folder"});
  EXPECT_TRUE(empty.names().empty());
}

TEST(Registry, TheFirstFolderIsRelativeToTheProgramHoldingTheCore) {
  // The core is linked into this test program: <program dir>/../lib/frichb/plugins.
  const fs::path program = fs::canonical("/proc/self/exe");
  std::error_code ec;
  EXPECT_EQ(frichb::core::core_binary_location(ec), program);
  EXPECT_FALSE(ec) << ec.message();
  const auto path = Registry::default_search_path();
  ASSERT_FALSE(path.empty());
  EXPECT_EQ(path.front(), program.parent_path().parent_path() / "lib/frichb/plugins");
}

TEST(Registry, TheFirstFolderIsRelativeToTheModuleHoldingTheCore) {
  // A module linking the core (as a Python extension does) searches beside itself, not
  // beside the program that loaded it.
  const fs::path module_dir = FRICHB_TEST_CORE_MODULE_DIR;
  const boost::dll::shared_library module(
      module_dir / "bin" / "frichb_test_core_module.so",
      boost::dll::load_mode::rtld_lazy | boost::dll::load_mode::rtld_local);
  const auto first = module.get<const char*()>("frichb_test_first_plugin_folder");
  EXPECT_EQ(fs::path(first()), module_dir / "lib/frichb/plugins");
}

TEST(Registry, LoadsAContactLawWithVersionSummaryAndSchema) {
  const Registry registry({kPluginDir});
  const auto plugin = registry.load("jenkins_1d", FRICHB_KIND_CONTACT_LAW);
  ASSERT_NE(plugin, nullptr);
  EXPECT_EQ(plugin->name(), "jenkins_1d");
  EXPECT_EQ(plugin->kind(), FRICHB_KIND_CONTACT_LAW);
  const auto& d = plugin->descriptor();
  EXPECT_EQ(d.abi_major, static_cast<unsigned>(FRICHB_ABI_MAJOR));
  EXPECT_EQ(std::string(d.version), "1.0.0");
  EXPECT_THAT(std::string(d.summary), HasSubstr("Coulomb slider"));
  EXPECT_NE(d.contact_law, nullptr);
  EXPECT_EQ(d.structure, nullptr);
  EXPECT_EQ(plugin->file().filename(), "frichb_jenkins_1d.so");

  const auto names = schema_names(plugin->schema());
  EXPECT_THAT(names, Contains("kt"));
  EXPECT_THAT(names, Contains("mu"));
  for (const auto& s : plugin->schema()) {
    if (std::string(s.name) == "kt") {
      EXPECT_EQ(s.type, FRICHB_PARAM_REAL);
      EXPECT_EQ(std::string(s.unit), "N/m");
      EXPECT_EQ(s.required, 1);
    }
  }
  // Loaded once: a second call returns the same object.
  EXPECT_EQ(registry.load("jenkins_1d", FRICHB_KIND_CONTACT_LAW), plugin);
  EXPECT_EQ(registry.load_any("jenkins_1d"), plugin);
}

TEST(Registry, LoadsAStructureProvider) {
  const Registry registry({kPluginDir});
  const auto plugin = registry.load("lumped", FRICHB_KIND_STRUCTURE);
  EXPECT_EQ(plugin->kind(), FRICHB_KIND_STRUCTURE);
  EXPECT_NE(plugin->descriptor().structure, nullptr);
  EXPECT_THAT(schema_names(plugin->schema()), Contains("masses"));
}

TEST(Registry, RefusesAPluginOfAnotherKind) {
  const Registry registry({kPluginDir});
  const std::string message =
      message_of<PluginError>([&] { registry.load("jenkins_1d", FRICHB_KIND_STRUCTURE); });
  EXPECT_THAT(message, HasSubstr("'jenkins_1d'"));
  EXPECT_THAT(message, HasSubstr("contact_law"));
  EXPECT_THAT(message, HasSubstr("structure"));

  const std::string other =
      message_of<PluginError>([&] { registry.load("lumped", FRICHB_KIND_CONTACT_LAW); });
  EXPECT_THAT(other, HasSubstr("'lumped'"));
  EXPECT_THAT(other, HasSubstr("is a structure"));
  EXPECT_THAT(other, HasSubstr("not a contact_law"));
}

TEST(Registry, UnknownNameListsValidNamesAndTheClosestMatch) {
  const Registry registry({kPluginDir});
  const std::string message =
      message_of<PluginError>([&] { registry.load("jenkins_1dd", FRICHB_KIND_CONTACT_LAW); });
  EXPECT_THAT(message, HasSubstr("unknown plugin 'jenkins_1dd'"));
  EXPECT_THAT(message, HasSubstr("did you mean 'jenkins_1d'"));
  EXPECT_THAT(message, HasSubstr("jenkins_1d, "));  // the list of valid names, sorted
  EXPECT_THAT(message, HasSubstr("lumped"));
  EXPECT_THAT(message, HasSubstr(kPluginDir.string()));  // where it searched

  // Nothing close: no suggestion, but still the list.
  const std::string far =
      message_of<PluginError>([&] { registry.load_any("completely_different_name"); });
  EXPECT_THAT(far, Not(HasSubstr("did you mean")));
  EXPECT_THAT(far, HasSubstr("jenkins_1d"));
}

TEST(Registry, TwoFilesDeclaringTheSameNameAreFatal) {
  ASSERT_TRUE(fs::is_regular_file(kDupA / "frichb_test_duplicate_law.so"))
      << "build the target frichb_test_plugins";
  ASSERT_TRUE(fs::is_regular_file(kDupB / "frichb_test_duplicate_law.so"));
  // Each copy alone is fine.
  EXPECT_THAT(Registry({kDupA}).names(), Contains("duplicate_law"));
  EXPECT_THAT(Registry({kDupB}).names(), Contains("duplicate_law"));

  const std::string message = message_of<PluginError>([&] { Registry registry({kDupA, kDupB}); });
  EXPECT_THAT(message, HasSubstr("'duplicate_law'"));
  EXPECT_THAT(message, HasSubstr((kDupA / "frichb_test_duplicate_law.so").string()));
  EXPECT_THAT(message, HasSubstr((kDupB / "frichb_test_duplicate_law.so").string()));
}

TEST(Registry, TheSameFolderListedTwiceIsNotADuplicate) {
  EXPECT_NO_THROW({
    const Registry registry({kPluginDir, kPluginDir});
    EXPECT_THAT(registry.names(), Contains("jenkins_1d"));
    EXPECT_EQ(registry.load("jenkins_1d", FRICHB_KIND_CONTACT_LAW)->name(), "jenkins_1d");
  });
  // Also when spelt differently (the registry compares canonical paths).
  EXPECT_NO_THROW(Registry({kDupA, kDupA / ".." / "dup_a", kDupA / "."}));
}

TEST(Registry, RefusesAPluginBuiltAgainstAnotherAbi) {
  ASSERT_TRUE(fs::is_regular_file(kWrongAbiFile)) << "build the target frichb_test_plugins";
  const std::string message = message_of<PluginError>([&] { load_plugin_file(kWrongAbiFile); });
  EXPECT_THAT(message, HasSubstr(kWrongAbiFile.string()));
  EXPECT_THAT(message, HasSubstr("99."));
  EXPECT_THAT(message, HasSubstr("ABI 99."));
  EXPECT_THAT(message, HasSubstr("ABI " + std::to_string(FRICHB_ABI_MAJOR) + "."));
  EXPECT_EQ(FRICHB_ABI_MAJOR, 1);  // the message's "1." is the host's version

  // Discovery reads only the symbol table, so the name is listed; loading is refused.
  const Registry registry({kTestPluginDir});
  EXPECT_THAT(registry.names(), Contains("wrong_abi_law"));
  const std::string via_registry =
      message_of<PluginError>([&] { registry.load("wrong_abi_law", FRICHB_KIND_CONTACT_LAW); });
  EXPECT_THAT(via_registry, HasSubstr("ABI 99."));
  EXPECT_THAT(via_registry, HasSubstr(kWrongAbiFile.string()));
}

TEST(Registry, LoadPluginFileOfAMissingFileThrowsPluginError) {
  const fs::path missing = kTestPluginDir / "no_such_plugin.so";
  const std::string message = message_of<PluginError>([&] { load_plugin_file(missing); });
  EXPECT_THAT(message, HasSubstr(missing.string()));
}

// ---------------------------------------------------------------------------------------
// validate_params against the jenkins_1d schema
// ---------------------------------------------------------------------------------------

class JenkinsParams : public ::testing::Test {
 protected:
  void SetUp() override {
    plugin_ = registry_.load("jenkins_1d", FRICHB_KIND_CONTACT_LAW);
    schema_ = plugin_->schema();
  }
  const frichb_param_value& value(const frichb::core::ParamValues& values,
                                  const std::string& name) const {
    for (std::size_t i = 0; i < schema_.size(); ++i)
      if (name == schema_[i].name) return values.data()[i];
    throw std::invalid_argument("no parameter " + name);
  }
  frichb::core::ParamValues validate(const std::string& yaml) const {
    return validate_params(YAML::Load(yaml), schema_, "contacts[0].params",
                           YamlContext{"test.yaml"});
  }
  SceneError refused(const std::string& yaml) const {
    try {
      validate(yaml);
    } catch (const SceneError& e) {
      return e;
    }
    ADD_FAILURE() << "accepted: " << yaml;
    return SceneError("", 0, 0, "", "");
  }

  Registry registry_{{kPluginDir}};
  std::shared_ptr<const frichb::core::LoadedPlugin> plugin_;
  std::span<const frichb_param_spec> schema_;
};

TEST_F(JenkinsParams, ValidParamsFillDefaults) {
  const auto values = validate("{kt: 2.0e5, mu: 0.5}");
  ASSERT_EQ(values.size(), schema_.size());
  EXPECT_EQ(value(values, "kt").present, 1);
  EXPECT_DOUBLE_EQ(value(values, "kt").real, 2.0e5);
  EXPECT_DOUBLE_EQ(value(values, "mu").real, 0.5);
  EXPECT_EQ(value(values, "normal_load").present, 0);
  EXPECT_DOUBLE_EQ(value(values, "normal_load").real, 0.0);
  EXPECT_EQ(value(values, "kn").present, 0);
  EXPECT_DOUBLE_EQ(value(values, "kn").real, 0.0);
  EXPECT_DOUBLE_EQ(value(values, "gap").real, 0.0);

  const auto json = values.to_json(schema_);
  EXPECT_DOUBLE_EQ(json.at("normal_load").get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(json.at("kt").get<double>(), 2.0e5);

  // A given optional value is kept and marked present.
  const auto given = validate("{kt: 1.0e5, mu: 0.3, normal_load: 5}");
  EXPECT_EQ(value(given, "normal_load").present, 1);
  EXPECT_DOUBLE_EQ(value(given, "normal_load").real, 5.0);
  // mu >= 0 is inclusive.
  EXPECT_NO_THROW(validate("{kt: 1.0e5, mu: 0}"));
}

TEST_F(JenkinsParams, ValidatedParamsMakeAWorkingInstance) {
  const auto values = validate("{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  const ContactLawInstance law(plugin_, values);
  EXPECT_EQ(law.traits().state_size, 1);
  double state0[1] = {-1.0};
  law.initial_state(state0);
  EXPECT_EQ(state0[0], 0.0);
  // Stuck: T = kt u (mu N = 2.5 N, kt u = 2 N).
  const double u_prev[3] = {0, 0, 0}, u_now[3] = {1.0e-5, 0, 0};
  double force[3] = {9, 9, 9}, state1[1] = {9};
  std::string error;
  ASSERT_TRUE(law.step(state0, u_prev, u_now, force, state1, nullptr, &error)) << error;
  EXPECT_DOUBLE_EQ(force[0], 2.0);
  EXPECT_EQ(force[1], 0.0);
  EXPECT_EQ(force[2], 0.0);
  // Slipping: T = mu N.
  const double u_far[3] = {1.0e-3, 0, 0};
  ASSERT_TRUE(law.step(state0, u_prev, u_far, force, state1, nullptr, &error)) << error;
  EXPECT_DOUBLE_EQ(force[0], 2.5);
}

TEST_F(JenkinsParams, OutOfRangeNamesRuleFileAndLocation) {
  const SceneError e = refused("kt: 2.0e5\nmu: -0.1\n");
  const std::string what = e.what();
  EXPECT_THAT(what, HasSubstr("mu >= 0"));
  EXPECT_THAT(what, HasSubstr("value -0.1 violates mu >= 0"));
  EXPECT_THAT(what, HasSubstr("test.yaml:2:5:"));  // the value -0.1: line 2, column 5
  EXPECT_THAT(what, HasSubstr("contacts[0].params.mu"));
  EXPECT_EQ(e.file(), "test.yaml");
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.column(), 5);
  EXPECT_EQ(e.key_path(), "contacts[0].params.mu");

  // An exclusive bound says so.
  const std::string kt = refused("{kt: 0, mu: 0.5}").what();
  EXPECT_THAT(kt, HasSubstr("kt > 0"));
  EXPECT_THAT(kt, HasSubstr("test.yaml:1:6:"));
}

TEST_F(JenkinsParams, WrongTypeSaysExpectedAFiniteNumber) {
  const SceneError e = refused("mu: 0.5\nkt: abc\n");
  const std::string what = e.what();
  EXPECT_THAT(what, HasSubstr("expected a finite number"));
  EXPECT_THAT(what, HasSubstr("'abc'"));
  EXPECT_THAT(what, HasSubstr("test.yaml:2:5:"));
  EXPECT_EQ(e.key_path(), "contacts[0].params.kt");

  EXPECT_THAT(refused("{kt: .inf, mu: 0.5}").what(), HasSubstr("expected a finite number"));
  EXPECT_THAT(refused("{kt: [1, 2], mu: 0.5}").what(), HasSubstr("expected a finite number"));
}

TEST_F(JenkinsParams, UnknownKeySuggestsTheClosestOne) {
  const SceneError e = refused("kt2: 2.0e5\nmu: 0.5\n");
  const std::string what = e.what();
  EXPECT_THAT(what, HasSubstr("unknown key"));
  EXPECT_THAT(what, HasSubstr("did you mean 'kt'"));
  EXPECT_THAT(what, HasSubstr("test.yaml:1:1:"));
  EXPECT_EQ(e.key_path(), "contacts[0].params.kt2");
}

TEST_F(JenkinsParams, MissingRequiredValueIsRefused) {
  const SceneError e = refused("mu: 0.5\n");
  EXPECT_THAT(std::string(e.what()), HasSubstr("missing required value"));
  EXPECT_THAT(std::string(e.what()), HasSubstr("N/m"));
  EXPECT_EQ(e.key_path(), "contacts[0].params.kt");
  EXPECT_EQ(e.file(), "test.yaml");
}

}  // namespace
