// frichb: the command-line program. See `frichb --help` and docs/getting-started.md.
#include "cli.hpp"

int main(int argc, char** argv) {
  return frichb::app::run_command_line(argc, argv);
}
