# Host toolchain for the fuzz build: Debian's clang 14 (libFuzzer comes with
# libclang-rt-14-dev). Compiler selection only; flags live in the preset and targets.
set(CMAKE_C_COMPILER clang-14)
set(CMAKE_CXX_COMPILER clang++-14)
