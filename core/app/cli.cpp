// The command-line parser, help and exit-code epilogue of frichb (cli.hpp).
#include "cli.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <optional>
#include <sstream>

#include "frichb/core/commands/failure.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/exit_codes.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "frichb/core/support/output.hpp"
#include "frichb/core/support/version.hpp"

namespace frichb::app {
namespace {

using core::kExitOk;
using core::kExitUsage;

const char* kAbout =
    R"(frichb - steady-state forced response of structures with dry-friction contacts
(multiharmonic balance with AFT, pseudo-arclength continuation, plugin contact laws).)";

const char* kFooter =
    R"(Exit codes: 0 ok; 1 bad command line; 2 invalid input (scene, plugin, file, output folder);
            3 the curve ended before the end of the sweep (outputs written, see summary.json);
            4 internal error; 5 the outputs could not be written (disk full, I/O error: the
            output folder keeps its earlier results); 130/143 interrupted by SIGINT/SIGTERM
            (no output written).
Plugins are searched in <dir>/../lib/frichb/plugins, relative to the binary holding the
FricHB core (the frichb program, or the program or module linking the core), the install
prefix, $FRICHB_PLUGIN_PATH (':'-separated) and the scene's plugin_paths; a plugin found
only in a scene's plugin_paths is loaded (its code run) only with --allow-scene-plugins.
Documentation: docs/getting-started.md and docs/scene-reference.md.
)";

// Long options must be written out: an abbreviation that one verb's options make unique could
// mean another option after the next release.
constexpr int kStyle =
    po::command_line_style::default_style & ~po::command_line_style::allow_guessing;

// Help columns: the width of the rest of the help text.
constexpr unsigned kHelpWidth = 96;
constexpr unsigned kHelpDescriptionColumn = 28;

po::options_description common_options() {
  po::options_description d("Common options", kHelpWidth, kHelpDescriptionColumn);
  d.add_options()("help,h", "show this help")(
      "log-level", po::value<std::string>()->value_name("LEVEL"),
      "trace, debug, info (the default), warn, error or off")(
      "verbose,v", "debug messages too (the same as --log-level debug)")(
      "quiet,q", "warnings and errors only (the same as --log-level warn)");
  return d;
}

const char* kAllowScenePlugins =
    "load plugins from the folders the scene's (or loop input's) plugin_paths names; without "
    "it only the default search path and FRICHB_PLUGIN_PATH are loaded from, since loading a "
    "library runs its code";

po::options_description global_options() {
  po::options_description d = common_options();
  d.add_options()("version", "print the version and the plugin ABI")("allow-scene-plugins",
                                                                     kAllowScenePlugins);
  return d;
}

// The verb's own options: -o, its add_options, then the scene options.
po::options_description own_options(const Verb& verb) {
  po::options_description d("Options", kHelpWidth, kHelpDescriptionColumn);
  if (verb.writes_output)
    d.add_options()("output,o", po::value<std::string>()->value_name("DIR"),
                    ("output folder (default: " + verb.output_default + ")").c_str());
  if (verb.add_options) verb.add_options(d);
  if (verb.reads_scene)
    d.add_options()("set",
                    po::value<std::vector<std::string>>()->composing()->value_name("PATH=VALUE"),
                    "override a scene key (repeatable), typed like the key in the file: a "
                    "number, true/false, a word or a list, e.g. contacts.shroud.params.mu=0.2, "
                    "output.plots=false, output.friction_loops_at=[330,400]");
  if (verb.input_plugins) d.add_options()("allow-scene-plugins", kAllowScenePlugins);
  return d;
}

std::string synopsis(const Verb& verb) {
  std::string text = "frichb " + verb.name;
  if (!verb.arguments.empty()) text += " " + verb.arguments;
  return text;
}

const Verb* find_verb(const std::string& name) {
  for (const auto& verb : verbs())
    if (verb.name == name) return &verb;
  return nullptr;
}

// " (an option of modes, timesim)" when other verbs take the option `name` (with its
// dashes), else "".
std::string taken_by(const std::string& name) {
  // Boost matches long names without their dashes, short ones with theirs.
  const std::string key = name.starts_with("--") ? name.substr(2) : name;
  std::string owners;
  for (const auto& verb : verbs())
    if (own_options(verb).find_nothrow(key, false))
      owners += (owners.empty() ? "" : ", ") + verb.name;
  return owners.empty() ? "" : " (an option of " + owners + ")";
}

void print_global_help(std::ostream& out) {
  out << kAbout << "\n\nUsage: frichb VERB [ARGUMENTS] [OPTIONS]\n"
      << "       frichb VERB --help        that verb's arguments, options and an example\n"
      << "       frichb --version\n\nVerbs:\n";
  for (const auto& verb : verbs()) {
    std::string line = "  " + synopsis(verb);
    if (line.size() < 30)
      line.resize(30, ' ');
    else
      line += "\n" + std::string(30, ' ');
    out << line << verb.summary << "\n";
  }
  out << "  frichb help VERB            the same as frichb VERB --help\n\n"
      << global_options() << "\n"
      << kFooter;
}

void print_verb_help(const Verb& verb, std::ostream& out) {
  out << "Usage: " << synopsis(verb) << " [OPTIONS]\n\n" << verb.description << "\n\n";
  const auto own = own_options(verb);
  if (!own.options().empty()) out << own << "\n";
  out << common_options() << "\n";
  out << (verb.examples.size() > 1 ? "Examples:\n" : "Example:\n");
  for (const auto& example : verb.examples) out << "  " << example << "\n";
  out << "\nExit codes: 0 ok, 1 bad command line, 2 invalid input, 3 incomplete curve, "
         "4 internal error,\n5 outputs not written, 130/143 interrupted (frichb --help says "
         "more).\n";
}

// The log level the options ask for (info when none); nullopt after a usage error.
std::optional<spdlog::level::level_enum> log_level(const po::variables_map& global,
                                                   const po::variables_map& verb,
                                                   const std::string& who,
                                                   const std::string& help) {
  std::size_t given = 0;
  std::string text;
  for (const auto* vm : {&global, &verb}) {
    if (vm->count("log-level")) {
      ++given;
      text = (*vm)["log-level"].as<std::string>();
    }
    if (vm->count("verbose")) {
      ++given;
      text = "debug";
    }
    if (vm->count("quiet")) {
      ++given;
      text = "warn";
    }
  }
  if (given > 1) {
    usage_error(who, "give one of --log-level, -v and -q, once", help);
    return std::nullopt;
  }
  if (given == 0) return spdlog::level::info;
  const auto level = spdlog::level::from_str(text);
  if (level == spdlog::level::off && text != "off") {
    usage_error(who, "unknown log level '" + text + "' (trace, debug, info, warn, error or off)",
                help);
    return std::nullopt;
  }
  return level;
}

// The index in argv of the verb: the first word that is neither an option nor the value of
// a global option written apart from it (--log-level LEVEL). argc when there is none.
int verb_index(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string token = argv[i];
    if (token.size() > 1 && token[0] == '-') {
      if (token == "--log-level") ++i;
      continue;
    }
    return i;
  }
  return argc;
}

}  // namespace

int run_command_line(int argc, char** argv) {
  const int at = verb_index(argc, argv);
  po::variables_map global;
  try {
    const std::vector<std::string> tokens(argv + 1, argv + at);
    po::store(po::command_line_parser(tokens).options(global_options()).style(kStyle).run(),
              global);
  } catch (const po::error& e) {
    return usage_error("frichb",
                       std::string(e.what()) +
                           " (a verb's options follow the verb: frichb VERB --help lists them)",
                       "frichb --help");
  }
  std::string name = at < argc ? argv[at] : "";
  int first_argument = at + 1;
  bool help = false;
  if (name == "help") {  // frichb help [VERB]
    if (at + 1 >= argc) {
      print_global_help(std::cout);
      return kExitOk;
    }
    name = argv[at + 1];
    first_argument = argc;
    help = true;
  }
  if (name.empty()) {
    if (global.count("help")) {
      print_global_help(std::cout);
      return kExitOk;
    }
    if (global.count("version")) {
      std::cout << "frichb " << core::version() << " (plugin ABI " << FRICHB_ABI_MAJOR << "."
                << FRICHB_ABI_MINOR << ")\n";
      return kExitOk;
    }
    print_global_help(std::cerr);
    return kExitUsage;
  }
  const Verb* verb = find_verb(name);
  if (!verb) {
    std::vector<std::string> names;
    for (const auto& v : verbs()) names.push_back(v.name);
    const std::string near = core::closest_match(name, names);
    return usage_error(
        "frichb",
        "unknown verb '" + name + "'" + (near.empty() ? "" : " (did you mean '" + near + "'?)"),
        "frichb --help");
  }
  const std::string who = "frichb " + verb->name;
  const std::string help_hint = who + " --help";
  if (help || global.count("help")) {
    print_verb_help(*verb, std::cout);
    return kExitOk;
  }
  if (global.count("allow-scene-plugins") && !verb->input_plugins)
    return usage_error(who,
                       "--allow-scene-plugins is for the verbs that read a scene or a loop "
                       "input; " +
                           who + " reads none",
                       help_hint);

  Invocation call;
  call.verb = verb->name;
  try {
    po::options_description all = own_options(*verb);
    all.add(common_options());
    po::options_description hidden;
    hidden.add_options()("arguments", po::value<std::vector<std::string>>());
    all.add(hidden);
    po::positional_options_description positional;
    positional.add("arguments", -1);
    const std::vector<std::string> tokens(argv + first_argument, argv + argc);
    po::store(
        po::command_line_parser(tokens).options(all).positional(positional).style(kStyle).run(),
        call.options);
    po::notify(call.options);
  } catch (const po::unknown_option& e) {
    return usage_error(who, e.what() + taken_by(e.get_option_name()), help_hint);
  } catch (const po::error& e) {
    return usage_error(who, e.what(), help_hint);
  }
  if (call.options.count("help")) {
    print_verb_help(*verb, std::cout);
    return kExitOk;
  }
  if (call.options.count("arguments"))
    call.arguments = call.options["arguments"].as<std::vector<std::string>>();
  if (call.arguments.size() < verb->min_arguments || call.arguments.size() > verb->max_arguments)
    return usage_error(who, "expected " + verb->missing_arguments, help_hint);
  if (call.options.count("output")) call.output = call.options["output"].as<std::string>();

  const auto level = log_level(global, call.options, who, help_hint);
  if (!level) return kExitUsage;
  if (call.options.count("set")) {
    std::vector<core::SceneOverride> overrides;
    for (const auto& text : call.options["set"].as<std::vector<std::string>>()) {
      try {
        overrides.push_back(core::parse_scene_override(text));
      } catch (const std::invalid_argument& e) {
        return usage_error(
            who, "--set '" + text + "': " + e.what() + " (e.g. contacts.shroud.params.mu=0.3)",
            help_hint);
      }
    }
    call.overrides = std::move(overrides);
  }
  call.allow_scene_plugins =
      call.options.count("allow-scene-plugins") > 0 || global.count("allow-scene-plugins") > 0;
  auto logger = spdlog::stderr_color_mt("frichb");
  logger->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  spdlog::set_default_logger(logger);
  spdlog::set_level(*level);
  if (verb->polls_interrupts) core::install_interrupt_handlers(call.stop);

  try {
    return verb->run(call);
  } catch (...) {
    return core::report_failure("");
  }
}

core::SceneInput Invocation::scene_input() const {
  return {arguments.at(0), overrides, allow_scene_plugins};
}

std::filesystem::path Invocation::output_folder(const std::string& suffix) const {
  if (!output.empty()) return output;
  return std::filesystem::path("out") /
         (std::filesystem::path(arguments.at(0)).stem().string() + suffix);
}

int usage_error(const std::string& who, const std::string& message, const std::string& help) {
  std::cerr << who << ": " << message << "\nTry '" << help << "'.\n";
  return kExitUsage;
}

int usage_error(const Invocation& call, const std::string& message) {
  const std::string who = "frichb " + call.verb;
  return usage_error(who, message, who + " --help");
}

}  // namespace frichb::app
