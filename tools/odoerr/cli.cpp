#include "cli.hpp"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include <sys/wait.h>

namespace fs = std::filesystem;

namespace odoerr::cli {

bool writeFile(const fs::path& path, const std::string& text, std::string* err) {
  std::ofstream f(path, std::ios::binary);
  if (!f) {
    *err = "cannot open '" + path.string() + "' for writing: " + std::strerror(errno);
    return false;
  }
  f << text;
  f.close();
  if (!f) {
    *err = "failed to write '" + path.string() + "'";
    return false;
  }
  return true;
}

bool prepareOutDir(const fs::path& dir, std::string* err) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    *err = "cannot create output directory '" + dir.string() + "': " + ec.message();
    return false;
  }
  const fs::path probe = dir / ".odoerr-write-test";
  if (!writeFile(probe, "", err)) {
    *err = "output directory '" + dir.string() + "' is not writable: " + *err;
    return false;
  }
  fs::remove(probe, ec);
  return true;
}

std::string pythonInterpreter() {
  if (const char* p = std::getenv("ODOERR_PYTHON")) return p;
  // Debian's interpreter carries python3-matplotlib; a pyenv/venv python3 may not.
  if (fs::exists("/usr/bin/python3")) return "/usr/bin/python3";
  return "python3";
}

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

std::string scriptPath(const char* env_var, const char* fallback) {
  if (const char* p = std::getenv(env_var)) return p;
  return fallback;
}

int runPython(const std::string& script, const std::vector<std::string>& args) {
  std::string cmd = shellQuote(pythonInterpreter()) + " " + shellQuote(script);
  for (const auto& a : args) cmd += " " + shellQuote(a);
  const int rc = std::system(cmd.c_str());
  if (rc == -1) return 127;
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : 128;
}

void ProgressBar::operator()(int done, int total) {
  if (!tty_) {
    // Logs (CI, pipes): one line per quarter instead of carriage-return redraws.
    const int quarter = total > 0 ? done * 4 / total : 4;
    if (quarter == last_quarter_) return;
    last_quarter_ = quarter;
    const double secs = std::chrono::duration<double>(clock::now() - t0_).count();
    std::fprintf(stderr, "%s: %d/%d runs %.1f s\n", label_.c_str(), done, total, secs);
    return;
  }
  constexpr int kWidth = 40;
  const int filled = total > 0 ? done * kWidth / total : kWidth;
  const double secs = std::chrono::duration<double>(clock::now() - t0_).count();
  std::fprintf(stderr, "\r%s [", label_.c_str());
  for (int i = 0; i < kWidth; ++i) std::fputc(i < filled ? '#' : '.', stderr);
  std::fprintf(stderr, "] %d/%d runs %.1f s", done, total, secs);
  if (done >= total) std::fputc('\n', stderr);
  std::fflush(stderr);
}

void addTuningOptions(CLI::App* sub, TuningArgs* t) {
  sub->add_flag("--order-beams", t->tuning.order_beams,
                "fuse each scan's beams most consistent with the prior first (robust under a wide heading prior; "
                "two casts a beam)");
  sub->add_option("--range-sigma", t->tuning.range_sigma,
                  "range noise std (m) instead of the log's laser record (e.g. 0.1 for a map built from a grid)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--param-sigma", t->tuning.param_sigma,
                  "prior sigma of the systematic parameters (relative; default 0.2, the paper's)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--gate-nis", t->tuning.gate_nis, "innovation gate on the NIS (default 25: 5 sigma)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--k0", t->k0, "initial non-systematic estimate: K_w (diff) or K_rho,K_theta (sync); its sigma is 10x")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
}

bool applyK0(const TuningArgs& t, const std::string& drive, double* k0_w, double* k0_rho, double* k0_theta,
             std::string* error) {
  if (t.k0.empty()) return true;
  const std::size_t want = drive == "sync" ? 2 : 1;
  if (t.k0.size() != want) {
    *error = "--k0 takes " + std::to_string(want) + " value(s) for the " + drive + " drive";
    return false;
  }
  if (want == 2) {
    *k0_rho = t.k0[0];
    *k0_theta = t.k0[1];
  } else {
    *k0_w = t.k0[0];
  }
  return true;
}

}  // namespace odoerr::cli
