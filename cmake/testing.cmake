# twinray_add_test(NAME src... [LIBS lib...]): a doctest executable linked with the test
# main (tests/test_main.cpp), twinray::twinray and the CPU backend compiled once for all
# tests (twinray_test_cpu, tests/CMakeLists.txt), whose test cases become CTest tests
# named "NAME: case", each run with TWINRAY_TEST_ENV (the program caches of the build).
# Sources include test helpers as "support/...", "backend/..." (relative to tests/).
function(twinray_add_test name)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  add_executable(${name} ${ARG_UNPARSED_ARGUMENTS})
  target_link_libraries(${name} PRIVATE twinray_test_main twinray_test_cpu twinray::twinray
                                        ${ARG_LIBS})
  target_compile_options(${name} PRIVATE ${TWINRAY_WARNINGS})
  doctest_discover_tests(${name} TEST_PREFIX "${name}: "
                         PROPERTIES ENVIRONMENT "${TWINRAY_TEST_ENV}")
endfunction()
