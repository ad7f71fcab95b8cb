// odoerr-paper: `odoerr paper` alone, with the same options. It links only the experiment
// and its bound (odoerr::paper), so the main job (scripts/paper.sh) compiles in about a
// third of the time the whole tool takes.
#include "cli.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"odoerr-paper: the Monte Carlo of the paper's experiment (Section 5); the same as `odoerr paper`"};
  const auto run = odoerr::addPaperOptions(&app);
  CLI11_PARSE(app, argc, argv);
  return run();
}
