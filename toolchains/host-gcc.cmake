# Host toolchain: the machine's GCC. Compiler selection only; flags live in the targets.
set(CMAKE_C_COMPILER gcc)
set(CMAKE_CXX_COMPILER g++)
