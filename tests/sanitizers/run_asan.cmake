# Builds the CPU-path tests with AddressSanitizer + UndefinedBehaviorSanitizer (the
# `asan` preset of CMakePresets.json: its cache variables, build targets, test filter
# and environment are read from there, so the preset is the one definition) and runs
# them; any sanitizer report aborts its test, so this fails.
#   cmake -DSOURCE_DIR=<twinray> -DWORK_DIR=<build dir> -DGENERATOR=<gen> -DJOBS=<n>
#         -P run_asan.cmake
cmake_minimum_required(VERSION 3.21)
file(READ ${SOURCE_DIR}/CMakePresets.json presets)
string(JSON n_build LENGTH "${presets}" buildPresets)
math(EXPR last "${n_build} - 1")
foreach(i RANGE ${last})
  string(JSON name GET "${presets}" buildPresets ${i} name)
  if(name STREQUAL "asan")
    string(JSON n LENGTH "${presets}" buildPresets ${i} targets)
    math(EXPR n "${n} - 1")
    set(targets "")
    foreach(t RANGE ${n})
      string(JSON target GET "${presets}" buildPresets ${i} targets ${t})
      list(APPEND targets ${target})
    endforeach()
  endif()
endforeach()
string(JSON n_test LENGTH "${presets}" testPresets)
math(EXPR last "${n_test} - 1")
foreach(i RANGE ${last})
  string(JSON name GET "${presets}" testPresets ${i} name)
  if(name STREQUAL "asan")
    string(JSON filter GET "${presets}" testPresets ${i} filter include name)
    string(JSON asan_options GET "${presets}" testPresets ${i} environment ASAN_OPTIONS)
    string(JSON ubsan_options GET "${presets}" testPresets ${i} environment UBSAN_OPTIONS)
  endif()
endforeach()
if(NOT targets OR NOT filter)
  message(FATAL_ERROR "CMakePresets.json has no asan build or test preset")
endif()

function(step name)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name}: failed (${rc})\n${out}\n${err}")
  endif()
  message(STATUS "${name}: ok\n${out}")
endfunction()

# Reuses WORK_DIR between runs (an incremental rebuild); the preset's cache variables
# apply on every configure.
step("configure (preset asan)" ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR} --preset asan
     -G ${GENERATOR})
step("build ${targets}" ${CMAKE_COMMAND} --build ${WORK_DIR} -j ${JOBS} --target ${targets})
step("run under ASan+UBSan" ${CMAKE_COMMAND} -E env ASAN_OPTIONS=${asan_options}
     UBSAN_OPTIONS=${ubsan_options} ${CMAKE_COMMAND} -E chdir ${WORK_DIR} ctest -R "${filter}"
     --no-tests=error --output-on-failure -j ${JOBS})
