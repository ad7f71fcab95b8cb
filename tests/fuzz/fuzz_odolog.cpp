// libFuzzer target: the odolog v1 reader fed a whole file (parseOdolog on its text).
// A malformed file must give false and an error naming the line, never a crash.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "odoerr/sim/odolog.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  odoerr::sim::Odolog log;
  std::string error;
  const bool ok = odoerr::sim::parseOdolog(text, "fuzz.odolog", &log, &error);
  if (!ok && error.rfind("fuzz.odolog", 0) != 0) std::abort();  // errors name the file
  return 0;
}
