# A short libFuzzer session on each scene-loader target, for CI (tests/fuzz):
# configures this folder with clang, builds both targets, then runs each for its
# share of SECONDS on a scratch copy of the committed seed corpus. Any crash, sanitizer
# report, leak, timeout or out-of-memory fails the test and names the input that
# caused it (kept under WORK_DIR/artifacts/); commit it under tests/fuzz/regressions/.
#   cmake -DSOURCE_DIR=<twinray> -DWORK_DIR=<dir> -DCLANG=<clang++> -DSECONDS=<total>
#         -DGENERATOR=<gen> -P run_fuzz.cmake
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

step("configure fuzz/ with ${CLANG}" ${CMAKE_COMMAND} -S ${fuzz} -B ${build} -G ${GENERATOR}
     -DCMAKE_CXX_COMPILER=${CLANG})
step("build fuzz targets" ${CMAKE_COMMAND} --build ${build} -j 2)

# name | seed corpus | share of the time, percent | dictionary
set(targets "scene_json|${fuzz}/corpus/scene_json|65|${fuzz}/scene_json.dict"
            "obj_mesh|${fuzz}/corpus/obj|35|")
set(failed "")
foreach(t ${targets})
  string(REPLACE "|" ";" fields "${t}")
  list(GET fields 0 name)
  list(GET fields 1 seeds)
  list(GET fields 2 percent)
  list(GET fields 3 dict)
  math(EXPR seconds "${SECONDS} * ${percent} / 100")
  set(corpus ${WORK_DIR}/corpus/${name})
  set(artifacts ${WORK_DIR}/artifacts/${name}/)
  file(REMOVE_RECURSE ${corpus} ${artifacts})
  file(MAKE_DIRECTORY ${corpus} ${artifacts})
  set(options -max_total_time=${seconds} -timeout=10 -rss_limit_mb=2048 -max_len=16384
              -print_final_stats=1 -artifact_prefix=${artifacts})
  if(dict)
    list(APPEND options -dict=${dict})
  endif()
  execute_process(COMMAND ${build}/fuzz_${name} ${options} ${corpus} ${seeds}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(REGEX MATCH "stat::number_of_executed_units: *[0-9]+" runs "${err}")
  string(REGEX MATCH "cov: [0-9]+ ft: [0-9]+" coverage "${err}")
  message(STATUS "fuzz_${name}: ${seconds} s, ${runs}, final ${coverage}")
  if(NOT rc EQUAL 0)
    file(GLOB found ${artifacts}*)
    string(LENGTH "${err}" len)
    if(len GREATER 6000)
      math(EXPR start "${len} - 6000")
      string(SUBSTRING "${err}" ${start} -1 err)
    endif()
    message(SEND_ERROR "fuzz_${name} found a failure (${rc}); input: ${found}\n${err}\n"
                       "Reproduce: ${build}/fuzz_${name} <input>; then commit the input under "
                       "tests/fuzz/regressions/${name}/ and fix the loader.")
    list(APPEND failed ${name})
  endif()
endforeach()
if(failed)
  message(FATAL_ERROR "fuzzing failed: ${failed}")
endif()
