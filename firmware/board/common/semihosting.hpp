// ARM semihosting (bkpt 0xAB), the board's only I/O under QEMU: files on the host for the
// sensor tape and the telemetry, and the exit code.
#pragma once

#include <cstddef>
#include <cstdint>

namespace odoerr::board {

enum class FileMode : int { kReadBinary = 1, kWriteBinary = 5 };

/// Returns a handle >= 0, or -1.
int shOpen(const char* path, FileMode mode);
void shClose(int handle);
/// Reads up to n bytes; returns the number read (0 at end of file).
std::size_t shRead(int handle, void* buf, std::size_t n);
/// Writes n bytes; returns the number written.
std::size_t shWrite(int handle, const void* buf, std::size_t n);
/// Writes a NUL-terminated string to the debug console (QEMU: stderr).
void shPuts(const char* s);
/// Ends the emulation with an exit code (SYS_EXIT_EXTENDED).
[[noreturn]] void shExit(int code);

}  // namespace odoerr::board
