// odoerr_soak: the float32 soak (docs/reliability.md, "Float32 soak").
//   odoerr_soak [--drive sync|diff|both] [--cycles N] [--seed S] [--json FILE] [--k-paper]
// Prints each drive's figures as JSON; exit 0 when every check passes, 1 when one fails
// (each failure on stderr), 2 on a bad argument.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>

#include "soak.hpp"

namespace {
int usage(const char* msg) {
  std::fprintf(stderr, "odoerr_soak: %s\nusage: odoerr_soak [--drive sync|diff|both] [--cycles N] [--seed S] "
                       "[--json FILE] [--k-paper]\n", msg);
  return 2;
}
}  // namespace

int main(int argc, char** argv) {
  odoerr::soak::SoakOptions o;
  std::string drive = "both";
  std::string json;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--drive" && has) {
      drive = argv[++i];
    } else if (a == "--cycles" && has) {
      char* end = nullptr;
      o.cycles = std::strtol(argv[++i], &end, 10);
      if (*end != '\0' || o.cycles <= 0) return usage("--cycles takes a positive integer");
    } else if (a == "--seed" && has) {
      o.seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--json" && has) {
      json = argv[++i];
    } else if (a == "--k-paper") {
      o.k_start_truth = false;
    } else {
      return usage(("unknown or incomplete argument '" + a + "'").c_str());
    }
  }
  if (drive != "sync" && drive != "diff" && drive != "both") return usage("--drive takes sync, diff or both");
  // NEES windows: 100 per run, at least 1000 cycles each.
  o.nees_window = std::max(1000L, o.cycles / 100);
  std::string out = "[\n";
  std::string failures;
  bool first = true;
  for (const char* d : {"sync", "diff"}) {
    if (drive != "both" && drive != d) continue;
    const auto r = std::strcmp(d, "sync") == 0 ? odoerr::soak::runSync(o) : odoerr::soak::runDiff(o);
    out += (first ? "" : ",\n") + odoerr::soak::toJson(r);
    first = false;
    failures += odoerr::soak::checkResult(r);
  }
  out += "\n]\n";
  std::cout << out;
  if (!json.empty()) {
    std::ofstream f(json);
    if (!(f << out)) {
      std::fprintf(stderr, "odoerr_soak: cannot write '%s'\n", json.c_str());
      return 2;
    }
  }
  if (!failures.empty()) {
    std::cerr << failures;
    return 1;
  }
  return 0;
}
