#include "commands.hpp"

namespace odoerr {

void registerCommands(CLI::App& app, cli::Commands& cmds) {
  registerSimCommands(app, cmds);
  registerMapCompileCommand(app, cmds);
  registerMapCommands(app, cmds);
  registerEvaluateCommands(app, cmds);
  registerImportCommands(app, cmds);
  registerCalibrateCommand(app, cmds);
  registerBoundCommand(app, cmds);
}

}  // namespace odoerr
