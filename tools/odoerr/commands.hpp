// odoerr tool: the subcommand families that live in their own files (cmd_*.cpp). Each
// adds its subcommands to the app and registers what runs them.
#pragma once

#include "cli.hpp"

namespace odoerr {

/// Every family below, in the order `odoerr --help` lists them.
void registerCommands(CLI::App& app, cli::Commands& cmds);

/// paper (cmd_paper.cpp): its options added to `sub`; returns what runs it once parsed. The
/// stand-alone odoerr-paper adds them to its app itself.
std::function<int()> addPaperOptions(CLI::App* sub);
void registerPaperCommand(CLI::App& app, cli::Commands& cmds);
/// sim, tape, hal-tape (cmd_sim.cpp).
void registerSimCommands(CLI::App& app, cli::Commands& cmds);
/// map compile (cmd_map_compile.cpp).
void registerMapCompileCommand(CLI::App& app, cli::Commands& cmds);
/// map import, render, grid-from-carmen (cmd_map.cpp; the work is tools/map/odoerr_map.py).
void registerMapCommands(CLI::App& app, cli::Commands& cmds);
/// evaluate, umbmark (cmd_evaluate.cpp).
void registerEvaluateCommands(CLI::App& app, cli::Commands& cmds);
/// import optiodom|carmen (cmd_import.cpp).
void registerImportCommands(CLI::App& app, cli::Commands& cmds);
/// bound (cmd_bound.cpp).
void registerBoundCommand(CLI::App& app, cli::Commands& cmds);
/// calibrate (cmd_calibrate.cpp; the steps are tools/calibrate/odoerr_calibrate.py).
void registerCalibrateCommand(CLI::App& app, cli::Commands& cmds);

}  // namespace odoerr
