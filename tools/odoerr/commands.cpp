#include "commands.hpp"

namespace odoerr {

void registerCommands(CLI::App& app, cli::Commands& cmds) {
  (void)app;
  (void)cmds;
}

}  // namespace odoerr
