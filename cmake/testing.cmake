# twinray_add_test(NAME src... [LIBS lib...] [CPU lib]): a doctest executable linked with
# the test main (tests/test_main.cpp), twinray::twinray and the CPU backend compiled once
# for all tests and examples (twinray_generic_cpu, CMakeLists.txt; CPU names another
# twinray_cpu_instances library, for tests of the device code built with other
# options), whose test cases become CTest tests named "NAME: case", each run with
# TWINRAY_TEST_ENV (the program caches of the build).
# Sources include test helpers as "support/...", "backend/..." (relative to tests/).
function(twinray_add_test name)
  cmake_parse_arguments(ARG "" "CPU" "LIBS" ${ARGN})
  if(NOT ARG_CPU)
    set(ARG_CPU twinray_generic_cpu)
  endif()
  add_executable(${name} ${ARG_UNPARSED_ARGUMENTS})
  target_link_libraries(${name} PRIVATE twinray_test_main ${ARG_CPU} twinray::twinray
                                        ${ARG_LIBS})
  target_compile_options(${name} PRIVATE ${TWINRAY_WARNINGS})
  # The environment goes on the discovered tests from a script CTest reads after them:
  # doctest_discover_tests(PROPERTIES ENVIRONMENT ...) splits a list, and sets its first
  # entry alone.
  doctest_discover_tests(${name} TEST_PREFIX "${name}: " TEST_LIST ${name}_TESTS)
  set(env_script "${CMAKE_CURRENT_BINARY_DIR}/${name}_environment.cmake")
  file(WRITE "${env_script}"
       "if(${name}_TESTS)\n"
       "  set_tests_properties(\${${name}_TESTS} PROPERTIES ENVIRONMENT \"${TWINRAY_TEST_ENV}\")\n"
       "endif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${env_script}")
endfunction()
