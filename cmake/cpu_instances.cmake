# twinray_cpu_instances(NAME [compile options...]): a static library that holds the CPU
# backend compiled once in float and once in double (explicit instantiations, one
# translation unit each, so they build in parallel), and passes on the define
# TWINRAY_CPU_BACKEND_EXTERN that keeps every translation unit linking it from
# compiling its own copy (backend/cpu.hpp). The options must be those of the code that
# links it (-march=native, sanitizers come from the build's flags), so each set of flags
# gets a library of its own. A project that adds twinray with add_subdirectory() can
# call it too.
#
# Its translation units also get TWINRAY_CPU_CODEGEN_FLAGS: -fno-math-errno and
# -fno-trapping-math change no value (sqrt still rounds correctly; nothing reads errno
# or the floating-point exception flags) but let g++ compute both sides of a select in
# SIMD lanes, which the packet's ray-per-lane sphere test needs to vectorize
# (docs/performance.md). They stay off the twinray target, so a consumer's own code
# keeps its errno. With g++, -fschedule-insns -fsched-pressure also schedule the
# instructions before register allocation (off by default on x86), minding register
# pressure: the same code and values in another order, demo frames 0.97-0.98 of the
# time, the others level (docs/performance.md); compiling takes 9% longer.
if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
  set(TWINRAY_CPU_CODEGEN_FLAGS -fno-math-errno -fno-trapping-math)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    list(APPEND TWINRAY_CPU_CODEGEN_FLAGS -fschedule-insns -fsched-pressure)
  endif()
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    list(APPEND TWINRAY_CPU_CODEGEN_FLAGS "SHELL:-mllvm -inline-threshold=1000")
  endif()
else()
  set(TWINRAY_CPU_CODEGEN_FLAGS)
endif()

# -march=native also brings g++'s tuning for the build machine. For AMD's first Zen
# cores (-mtune=znver1) that tuning vectorizes 128 bits at a time, though the core runs
# AVX2's 256-bit instructions: each 16-ray group of the device code's lane loops took
# four instructions where two do. With Haswell's tuning instead (256-bit vectors, the
# same instructions, the same values) the CPU backend's frames took 0.945-0.983 of the
# time on such a machine; g++'s generic and znver3 tunings gained less
# (docs/performance.md). TWINRAY_NATIVE_TUNE is what the CPU backend's translation
# units compiled with -march=native add: -mtune=haswell where g++ picks znver1, else
# nothing (set it to choose another, or "" for the compiler's own choice).
set(twinray_native_tune_default "")
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  execute_process(COMMAND ${CMAKE_CXX_COMPILER} -march=native -Q --help=target
                  OUTPUT_VARIABLE twinray_native_target ERROR_QUIET RESULT_VARIABLE twinray_rc)
  if(twinray_rc EQUAL 0 AND twinray_native_target MATCHES "-mtune=[ \t]+znver1[ \t\r\n]")
    set(twinray_native_tune_default -mtune=haswell)
  endif()
endif()
set(TWINRAY_NATIVE_TUNE "${twinray_native_tune_default}" CACHE STRING
    "Tuning flags the CPU backend adds where it is compiled with -march=native")

# twinray_cpu_backend_options(TARGET [compile options...]): the options the CPU
# backend's translation units compile with, given the code's own (-march=native
# brings TWINRAY_NATIVE_TUNE), set on TARGET; also for bench/'s twinray_ab_side.
function(twinray_cpu_backend_options target)
  set(native_tune)
  if("-march=native" IN_LIST ARGN)
    set(native_tune ${TWINRAY_NATIVE_TUNE})
  endif()
  target_compile_options(${target} PRIVATE ${ARGN} ${native_tune} ${TWINRAY_CPU_CODEGEN_FLAGS})
endfunction()

function(twinray_cpu_instances name)
  set(sources)
  foreach(TWINRAY_INSTANCE_REAL float double)
    set(source ${CMAKE_CURRENT_BINARY_DIR}/${name}_${TWINRAY_INSTANCE_REAL}.cpp)
    configure_file(${CMAKE_CURRENT_FUNCTION_LIST_DIR}/cpu_backend_instance.cpp.in ${source} @ONLY)
    list(APPEND sources ${source})
  endforeach()
  add_library(${name} STATIC ${sources})
  target_link_libraries(${name} PUBLIC twinray::twinray)
  target_compile_definitions(${name} PUBLIC TWINRAY_CPU_BACKEND_EXTERN=1)
  twinray_cpu_backend_options(${name} ${ARGN})
endfunction()

# The twinray command and the Python module are built for the machine that builds them,
# as the benchmarks are: parity holds, since the twinray target keeps -ffp-contract=off,
# and the ISA tests show the same bits from SSE2, AVX2 and AVX-512 builds. A package or
# wheel for other machines turns it off. Library consumers choose their own flags.
option(TWINRAY_NATIVE "Build the twinray command and the Python module with -march=native" ON)

# twinray_program_flags(VAR): the compile options of those programs, TWINRAY_WARNINGS and,
# with TWINRAY_NATIVE, -march=native; for their sources and their twinray_cpu_instances().
function(twinray_program_flags out)
  set(flags ${TWINRAY_WARNINGS})
  if(TWINRAY_NATIVE AND CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    list(APPEND flags -march=native)
  endif()
  set(${out} ${flags} PARENT_SCOPE)
endfunction()
