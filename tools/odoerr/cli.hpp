// odoerr tool: what every subcommand shares (file output, the Python interpreter, a
// progress bar) and the registry through which a subcommand family in its own file joins
// the tool (cmd_*.cpp: one family per file, one hook in main.cpp).
#pragma once

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <unistd.h>

#include "odoerr/sim/filter_tuning.hpp"

namespace odoerr::cli {

/// Writes a whole file or explains why not (naming the path).
bool writeFile(const std::filesystem::path& path, const std::string& text, std::string* err);

/// Creates DIR and proves it writable before any long computation starts.
bool prepareOutDir(const std::filesystem::path& dir, std::string* err);

/// The Python that runs the plot and report scripts: $ODOERR_PYTHON, else Debian's.
std::string pythonInterpreter();

/// s quoted for /bin/sh.
std::string shellQuote(const std::string& s);

/// A script shipped with the tool: $ENV_VAR when set, else the build's default path.
std::string scriptPath(const char* env_var, const char* fallback);

/// Runs `python3 SCRIPT ARGS...` (each argument quoted); returns its exit status.
int runPython(const std::string& script, const std::vector<std::string>& args);

/// A progress line on stderr: redrawn on a terminal, a line per quarter in logs.
class ProgressBar {
 public:
  explicit ProgressBar(std::string label) : label_(std::move(label)), t0_(clock::now()) {}
  void operator()(int done, int total);

 private:
  using clock = std::chrono::steady_clock;
  std::string label_;
  clock::time_point t0_;
  bool tty_ = isatty(fileno(stderr)) != 0;
  int last_quarter_ = -1;
};

/// The subcommand `name` of app (a family such as `map`, shared by several files),
/// created with `description` when no file has created it yet.
inline CLI::App* family(CLI::App& app, const std::string& name, const std::string& description) {
  const auto found = app.get_subcommands([&name](CLI::App* a) { return a->get_name() == name; });
  if (!found.empty()) return found.front();
  CLI::App* sub = app.add_subcommand(name, description);
  sub->require_subcommand(1);
  return sub;
}

/// Subcommands registered by their own files. A registration adds its subcommand to the
/// app and returns the function that runs it once parsed (its exit status).
class Commands {
 public:
  void add(CLI::App* sub, std::function<int()> run) { cmds_.push_back({sub, std::move(run)}); }
  /// The exit status of the parsed registered subcommand, or -1 when none of them was parsed.
  int runParsed() const {
    for (const auto& c : cmds_)
      if (c.sub->parsed()) return c.run();
    return -1;
  }

 private:
  struct Entry {
    CLI::App* sub;
    std::function<int()> run;
  };
  std::vector<Entry> cmds_;
};

/// The real-robot filter settings a subcommand takes (replay, diagnose): --order-beams,
/// --range-sigma, --param-sigma, --gate-nis, --k0. The paper's settings are the defaults.
struct TuningArgs {
  sim::FilterTuning tuning;
  std::vector<double> k0;
};
void addTuningOptions(CLI::App* sub, TuningArgs* t);
/// --k0 into the drive's initial K (1 value for diff, 2 for sync); false with *error.
bool applyK0(const TuningArgs& t, const std::string& drive, double* k0_w, double* k0_rho, double* k0_theta,
             std::string* error);

}  // namespace odoerr::cli
