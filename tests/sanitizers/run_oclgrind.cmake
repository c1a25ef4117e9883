# Runs `twinray render` under Oclgrind (Debian oclgrind), the OpenCL simulator that
# checks every memory access of every work-item, and fails on any report: out-of-bounds
# reads and writes (always on), data races (--data-races), invalid API use
# (--check-api), and with UNINITIALIZED=ON reads of uninitialized memory
# (--uninitialized). The kernel is built with -cl-opt-disable: Oclgrind 21.10 knows
# neither the `freeze` instruction nor the `llvm.fshl` intrinsic that LLVM 14's
# optimizer emits (the rotations of the samplers), and unoptimized code has every
# access the source has. It is also built with -DTR_NO_ALWAYS_INLINE: clang's
# always-inliner runs even unoptimized and emits llvm.experimental.noalias.scope.decl,
# which Oclgrind 21.10 does not know either; inlining changes no memory access. And
# with -DTR_LIBRARY_MATH: OpenCL C's fabs and sqrt instead of clang's built-ins
# (device/math.h), whose llvm.fabs and llvm.sqrt Oclgrind 21.10 does not know; the same
# values. The image must also be bit for bit the CPU backend's.
#   cmake -DTWINRAY=<exe> -DOCLGRIND=<exe> -DWORK_DIR=<dir> -DSCENE=<json|demo>
#         -DARGS="<extra render args>" [-DUNINITIALIZED=ON] -P run_oclgrind.cmake
cmake_minimum_required(VERSION 3.19)
separate_arguments(ARGS UNIX_COMMAND "${ARGS}")
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(log ${WORK_DIR}/oclgrind.log)
set(tools --check-api --data-races --build-options
          "-cl-opt-disable -DTR_NO_ALWAYS_INLINE -DTR_LIBRARY_MATH")
if(UNINITIALIZED)
  list(APPEND tools --uninitialized)
endif()
# TWINRAY_CACHE_DIR empty: no program binaries, the kernel is built by Oclgrind itself.
# Oclgrind is a CPU device: the block kernel, from the first frame on.
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env TWINRAY_CACHE_DIR= TWINRAY_OPENCL_FIRST_FRAME=blocks
          ${OCLGRIND} ${tools} --log ${log}
          ${TWINRAY} render ${SCENE} -o ${WORK_DIR}/opencl.pfm --backend opencl --quiet ${ARGS}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message(STATUS "${out}${err}")
set(report "")
if(EXISTS ${log})
  file(READ ${log} report)
endif()
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "twinray under Oclgrind failed (${rc}):\n${out}${err}\n${report}")
endif()
if(NOT report STREQUAL "")
  message(FATAL_ERROR "Oclgrind reported problems in the kernel:\n${report}")
endif()
string(FIND "${out}" "backend opencl (Oclgrind" at)
if(at EQUAL -1)
  message(FATAL_ERROR "the render did not run on the Oclgrind device:\n${out}${err}")
endif()
execute_process(COMMAND ${TWINRAY} render ${SCENE} -o ${WORK_DIR}/cpu.pfm --backend cpu --quiet
                        ${ARGS} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "CPU render failed (${rc}):\n${out}${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK_DIR}/cpu.pfm
                        ${WORK_DIR}/opencl.pfm RESULT_VARIABLE differ)
if(NOT differ EQUAL 0)
  message(FATAL_ERROR "the image from Oclgrind differs from the CPU backend's")
endif()
message(STATUS "Oclgrind: no reports; image identical to the CPU backend's")
