// Link-time heap trap. The firmware links with --wrap for every allocator entry point,
// so any use of the heap resolves to one of these functions; they reference a symbol that
// exists nowhere, and the link fails naming it. This file is built into a static library:
// its object is pulled in (and the link broken) only when something allocates.
#include <cstddef>

extern "C" {
void odoerr_firmware_must_not_use_the_heap();  // never defined, on purpose

void* __wrap_malloc(std::size_t) {
  odoerr_firmware_must_not_use_the_heap();
  return nullptr;
}
void* __wrap_calloc(std::size_t, std::size_t) {
  odoerr_firmware_must_not_use_the_heap();
  return nullptr;
}
void* __wrap_realloc(void*, std::size_t) {
  odoerr_firmware_must_not_use_the_heap();
  return nullptr;
}
void __wrap_free(void*) { odoerr_firmware_must_not_use_the_heap(); }
void* __wrap__malloc_r(void*, std::size_t) {
  odoerr_firmware_must_not_use_the_heap();
  return nullptr;
}
}
