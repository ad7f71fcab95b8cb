// libFuzzer target, built on request (`cmake --build --preset fuzz --target fuzz_pipeline`;
// docs/reliability.md, "Fuzzing"): the input as a log's text through the host pipeline (the
// reader, replay, diagnose), with tests/pipeline_check.hpp's rules as the oracle. A rule
// broken is printed and aborts, so libFuzzer keeps the input.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "pipeline_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string work = (std::filesystem::temp_directory_path() / "odoerr-fuzz-pipeline").string();
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string why = odoerr::sim::test::checkPipeline(text, "fuzz.odolog", work, true);
  if (!why.empty()) {
    std::fprintf(stderr, "fuzz_pipeline: %s\n", why.c_str());
    std::abort();
  }
  return 0;
}
