# Cortex-M4F hard-float flags, carried by targets (not by the toolchain file), shared by the
# boards: odoerr_cortex_m4f_flags(NAME LINKER_SCRIPT DEFINITION) makes the INTERFACE library
# NAME with the compile and link options, the board's linker script and its definition.
function(odoerr_cortex_m4f_flags name linker_script board_definition)
  add_library(${name} INTERFACE)
  target_compile_options(${name} INTERFACE
    -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16
    -O2 -ffunction-sections -fdata-sections
    -fno-math-errno -ffp-contract=off
    $<$<COMPILE_LANGUAGE:CXX>:-fno-exceptions -fno-rtti -fno-threadsafe-statics>
    -fno-unwind-tables -fno-asynchronous-unwind-tables -fstack-usage)
  target_compile_definitions(${name} INTERFACE
    ${board_definition} EIGEN_NO_IO EIGEN_ALLOCA=__builtin_alloca EIGEN_NO_DEBUG)
  target_link_options(${name} INTERFACE
    -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16
    -specs=nano.specs -nostartfiles -Wl,--gc-sections
    -T${linker_script}
    # Link-time heap trap: every allocator entry point resolves to heap_trap.cpp.
    -Wl,--wrap=malloc -Wl,--wrap=calloc -Wl,--wrap=realloc -Wl,--wrap=free -Wl,--wrap=_malloc_r)
endfunction()
