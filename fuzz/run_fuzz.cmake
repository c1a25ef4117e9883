# A short libFuzzer session on the scene loader, for CI (tests/fuzz), in two steps so
# that CTest can run the two targets side by side:
#   -DMODE=build: configures this folder with clang and builds both targets
#   -DMODE=run -DTARGET=scene_json|obj_mesh: runs that target for SECONDS on a scratch
#     copy of the committed seed corpus and the inputs it once crashed on
# Any crash, sanitizer report, leak, timeout or out-of-memory fails the test and names
# the input that caused it (kept under WORK_DIR/artifacts/); commit it under
# tests/fuzz/regressions/<target>/.
#   cmake -DMODE=build -DSOURCE_DIR=<twinray> -DWORK_DIR=<dir> -DCLANG=<clang++>
#         -DGENERATOR=<gen> -P run_fuzz.cmake
#   cmake -DMODE=run -DTARGET=<target> -DSOURCE_DIR=<twinray> -DWORK_DIR=<dir>
#         -DSECONDS=<n> -P run_fuzz.cmake
cmake_minimum_required(VERSION 3.19)
set(fuzz ${SOURCE_DIR}/fuzz)
set(build ${WORK_DIR}/build)

function(step name)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name}: failed (${rc})\n${out}\n${err}")
  endif()
  message(STATUS "${name}: ok")
endfunction()

if(MODE STREQUAL "build")
  step("configure fuzz/ with ${CLANG}" ${CMAKE_COMMAND} -S ${fuzz} -B ${build} -G ${GENERATOR}
       -DCMAKE_CXX_COMPILER=${CLANG})
  step("build fuzz targets" ${CMAKE_COMMAND} --build ${build} -j 2)
  return()
endif()

set(name ${TARGET})
if(name STREQUAL "scene_json")
  set(seeds ${fuzz}/corpus/scene_json)
  set(extra -dict=${fuzz}/scene_json.dict)
elseif(name STREQUAL "obj_mesh")
  set(seeds ${fuzz}/corpus/obj)
  set(extra "")
else()
  message(FATAL_ERROR "TARGET must be scene_json or obj_mesh")
endif()
set(corpus ${WORK_DIR}/corpus/${name})
set(artifacts ${WORK_DIR}/artifacts/${name}/)
file(REMOVE_RECURSE ${corpus} ${artifacts})
file(MAKE_DIRECTORY ${corpus} ${artifacts})
execute_process(COMMAND ${build}/fuzz_${name} -max_total_time=${SECONDS} -timeout=10
                        -rss_limit_mb=2048 -max_len=16384 -print_final_stats=1
                        -artifact_prefix=${artifacts} ${extra} ${corpus} ${seeds}
                        ${SOURCE_DIR}/tests/fuzz/regressions/${name}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCH "stat::number_of_executed_units: *[0-9]+" runs "${err}")
string(REGEX MATCHALL "cov: [0-9]+ ft: [0-9]+" coverages "${err}")
list(POP_BACK coverages coverage)
message(STATUS "fuzz_${name}: ${SECONDS} s, ${runs}, final ${coverage}")
if(NOT rc EQUAL 0)
  file(GLOB found ${artifacts}*)
  string(LENGTH "${err}" len)
  if(len GREATER 6000)
    math(EXPR start "${len} - 6000")
    string(SUBSTRING "${err}" ${start} -1 err)
  endif()
  message(FATAL_ERROR "fuzz_${name} found a failure (${rc}); input: ${found}\n${err}\n"
                      "Reproduce: ${build}/fuzz_${name} <input>; then commit the input under "
                      "tests/fuzz/regressions/${name}/ and fix the loader.")
endif()
