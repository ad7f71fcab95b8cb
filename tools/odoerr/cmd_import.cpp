// odoerr tool: `odoerr import optiodom|carmen ARGS...`, the importers (Python, in
// tools/import) run from the same tool: every argument goes to the script as given.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli.hpp"
#include "commands.hpp"

namespace odoerr {

void registerImportCommands(CLI::App& app, cli::Commands& cmds) {
  CLI::App* imp = cli::family(app, "import", "convert a dataset's log to odolog (the Python importers)");
  struct Importer {
    const char* name;
    const char* script;
    const char* help;
  };
  static const Importer kImporters[] = {
      {"optiodom", "optiodom_to_odolog.py", "an OptiOdom run CSV (wheel ticks + motion capture): RUN.csv --out LOG [--fix-period S ...]"},
      {"carmen", "carmen_to_odolog.py", "a SLAM-corrected CARMEN log (five buildings read): LOG --out FILE [--scans] [--auto] [--time ...] [--max-scans N]"},
  };
  for (const Importer& im : kImporters) {
    CLI::App* sub = imp->add_subcommand(im.name, im.help);
    sub->allow_extras();
    sub->prefix_command();  // everything after the name goes to the script,
    sub->set_help_flag();   // --help too (the script's own help)
    const std::string script = std::string(ODOERR_IMPORT_DIR) + "/" + im.script;
    cmds.add(sub, [sub, script]() {
      const std::vector<std::string> args = sub->remaining();
      const std::string path = cli::scriptPath("ODOERR_IMPORT_DIR", ODOERR_IMPORT_DIR) + "/" +
                               script.substr(script.find_last_of('/') + 1);
      const int rc = cli::runPython(path, args);
      if (rc == 127) std::fprintf(stderr, "odoerr import: cannot run %s (set ODOERR_PYTHON)\n", path.c_str());
      return rc;
    });
  }
}

}  // namespace odoerr
