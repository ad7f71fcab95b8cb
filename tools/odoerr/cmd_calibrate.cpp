// odoerr tool: `odoerr calibrate LOG --out DIR [--map MAP]`, one command from a real log to a
// verdict. The steps (import, map, tracking, calibration, check, diagnosis) are odoerr's own
// commands and importers, chained by tools/calibrate/odoerr_calibrate.py; every argument goes
// to it as given, with this executable's path (docs/calibrate.md).
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "cli.hpp"
#include "commands.hpp"

namespace odoerr {

void registerCalibrateCommand(CLI::App& app, cli::Commands& cmds) {
  CLI::App* sub = app.add_subcommand(
      "calibrate", "a real log to a calibration you can trust: LOG --out DIR [--map MAP] (--help: the steps)");
  sub->allow_extras();
  sub->prefix_command();  // everything after the name goes to the script,
  sub->set_help_flag();   // --help too (the script's own help)
  cmds.add(sub, [sub]() {
    std::error_code ec;
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (ec) {
      std::fprintf(stderr, "odoerr calibrate: cannot find this executable's path: %s\n", ec.message().c_str());
      return 1;
    }
    std::vector<std::string> args{"--odoerr", self.string()};
    for (const std::string& a : sub->remaining()) args.push_back(a);
    const std::string script = cli::scriptPath("ODOERR_CALIBRATE_SCRIPT", ODOERR_CALIBRATE_SCRIPT);
    const int rc = cli::runPython(script, args);
    if (rc == 127) std::fprintf(stderr, "odoerr calibrate: cannot run %s (set ODOERR_PYTHON)\n", script.c_str());
    return rc;
  });
}

}  // namespace odoerr
