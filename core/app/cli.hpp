// The command line of frichb: `frichb [GLOBAL OPTIONS] VERB [ARGUMENTS] [OPTIONS]`, on
// Boost.program_options. Each verb declares its own options; its --help prints them with an
// example; an option another verb takes is refused. Every verb takes the common options
// (--help, --log-level, -v, -q) before or after its name.
#pragma once

#include <boost/program_options.hpp>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/interrupt.hpp"

namespace frichb::app {

namespace po = boost::program_options;

// One verb's command line once parsed.
struct Invocation {
  std::string verb;
  std::vector<std::string> arguments;          // the positional arguments after the verb
  po::variables_map options;                   // the verb's own options (and the common ones)
  std::string output;                          // -o DIR, empty when not given
  std::vector<core::SceneOverride> overrides;  // --set PATH=VALUE, in order
  bool allow_scene_plugins = false;            // --allow-scene-plugins (before or after the verb)
  core::StopSource stop;  // stops the call's tokens; SIGINT/SIGTERM do (polls_interrupts)

  // The scene input of a verb that reads one: the first argument, the overrides and the
  // plugin permission.
  core::SceneInput scene_input() const;
  // The output folder: -o DIR, or out/<first argument's stem><suffix>.
  std::filesystem::path output_folder(const std::string& suffix) const;
};

struct Verb {
  std::string name;
  std::string arguments;              // as the synopsis shows them: "SCENE.yaml", "NAME", ""
  std::size_t min_arguments = 0;      // positional arguments required
  std::size_t max_arguments = 0;      // and allowed
  std::string missing_arguments;      // "one scene file": the error when the count is wrong
  std::string summary;                // one line for `frichb --help`
  std::string description;            // the paragraphs of `frichb VERB --help`
  std::vector<std::string> examples;  // whole command lines
  bool reads_scene = false;           // takes --set (applied to every scene it reads)
  bool input_plugins = false;         // takes --allow-scene-plugins
  bool writes_output = false;         // takes -o DIR
  std::string output_default;         // what -o defaults to, for the help
  bool polls_interrupts = false;      // SIGINT/SIGTERM stop its call's token (interrupt.hpp)
  std::function<void(po::options_description&)> add_options;  // its own options, may be empty
  std::function<int(const Invocation&)> run;                  // returns an exit code
};

// The verbs, in the order `frichb --help` lists them (verbs.cpp).
const std::vector<Verb>& verbs();

// Parses the command line, sets up logging and the scene overrides, runs the verb and maps
// what escapes it to an exit code (core/include/frichb/core/commands/run.hpp's ExitCode).
int run_command_line(int argc, char** argv);

// A usage error: prints "WHO: MESSAGE" and "Try 'HELP'." to stderr and returns kExitUsage (1).
int usage_error(const std::string& who, const std::string& message, const std::string& help);
// The same for a verb's value found out of range after parsing ("frichb VERB: ...").
int usage_error(const Invocation& call, const std::string& message);

}  // namespace frichb::app
