#include "semihosting.hpp"

#include <cstring>

namespace odoerr::board {
namespace {
enum : int {
  kSysOpen = 0x01,
  kSysClose = 0x02,
  kSysWrite0 = 0x04,
  kSysWrite = 0x05,
  kSysRead = 0x06,
  kSysExitExtended = 0x20,
};
constexpr std::uint32_t kAdpStoppedApplicationExit = 0x20026;

int call(int op, const void* arg) {
  register int r0 __asm__("r0") = op;
  register const void* r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}
}  // namespace

int shOpen(const char* path, FileMode mode) {
  const std::uint32_t args[3] = {reinterpret_cast<std::uint32_t>(path), static_cast<std::uint32_t>(mode),
                                 static_cast<std::uint32_t>(std::strlen(path))};
  return call(kSysOpen, args);
}

void shClose(int handle) {
  const std::uint32_t args[1] = {static_cast<std::uint32_t>(handle)};
  (void)call(kSysClose, args);
}

std::size_t shRead(int handle, void* buf, std::size_t n) {
  const std::uint32_t args[3] = {static_cast<std::uint32_t>(handle), reinterpret_cast<std::uint32_t>(buf),
                                 static_cast<std::uint32_t>(n)};
  const int not_read = call(kSysRead, args);  // bytes NOT read
  return not_read < 0 ? 0 : n - static_cast<std::size_t>(not_read);
}

std::size_t shWrite(int handle, const void* buf, std::size_t n) {
  const std::uint32_t args[3] = {static_cast<std::uint32_t>(handle), reinterpret_cast<std::uint32_t>(buf),
                                 static_cast<std::uint32_t>(n)};
  const int not_written = call(kSysWrite, args);
  return not_written < 0 ? 0 : n - static_cast<std::size_t>(not_written);
}

void shPuts(const char* s) { (void)call(kSysWrite0, s); }

void shExit(int code) {
  const std::uint32_t args[2] = {kAdpStoppedApplicationExit, static_cast<std::uint32_t>(code)};
  (void)call(kSysExitExtended, args);
  for (;;) {
  }
}

}  // namespace odoerr::board
