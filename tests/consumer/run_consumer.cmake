# Drives the consumer project (tests/consumer/project) the way a user adopts twinray.
#   cmake -DMODE=installed|subdirectory -DSOURCE_DIR=<twinray> -DWORK_DIR=<scratch>
#         -DGENERATOR=<gen> [-DCXX=<compiler>] [-DHOST_PROCESSOR=x86_64]
#         [-DFLAGS=<subdirectory mode: CMAKE_CXX_FLAGS, Release>] [-DSCENES=a.json;b.json]
#         -P run_consumer.cmake
# installed:    copy the source tree, configure, `cmake --install` it into a prefix (the
#               headers, the CMake package and bin/twinray, which must render alone),
#               DELETE the copy and its build folder, check the installed files name
#               neither, check find_package's version and component handling, then build
#               the consumer with find_package() and its own flags (-O3 -march=native
#               -ffp-contract=fast) and run it: OpenCL renders and matches the CPU bit
#               for bit with no source tree left.
# subdirectory: build the consumer with add_subdirectory(<twinray>) and run it.
cmake_minimum_required(VERSION 3.19)
foreach(var MODE SOURCE_DIR WORK_DIR GENERATOR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_consumer.cmake: -D${var}=... is required")
  endif()
endforeach()

set(compiler_args "")
if(CXX)
  set(compiler_args -DCMAKE_CXX_COMPILER=${CXX})
endif()

# Runs a command; stops the test with its output when its exit status is not `expect`.
function(step name expect)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(expect STREQUAL "0" AND NOT rc EQUAL 0)
    message(FATAL_ERROR "${name}: failed (${rc})\n${out}\n${err}")
  elseif(expect STREQUAL "fail" AND rc EQUAL 0)
    message(FATAL_ERROR "${name}: succeeded but must fail\n${out}\n${err}")
  endif()
  set(step_output "${out}${err}" PARENT_SCOPE)
  message(STATUS "${name}: ok")
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(env ${CMAKE_COMMAND} -E env TWINRAY_CACHE_DIR=${WORK_DIR}/cache/twinray
        POCL_CACHE_DIR=${WORK_DIR}/cache/pocl)
# The example scenes with the files they name (SCENES picks which to render; default the
# demo), kept outside any tree that gets deleted.
if(NOT SCENES)
  set(SCENES demo.json)
endif()
file(COPY ${SOURCE_DIR}/examples/scenes/ DESTINATION ${WORK_DIR})

if(MODE STREQUAL "installed")
  set(copy ${WORK_DIR}/src)
  set(prefix ${WORK_DIR}/prefix)
  file(MAKE_DIRECTORY ${copy})
  file(COPY ${SOURCE_DIR}/CMakeLists.txt ${SOURCE_DIR}/include ${SOURCE_DIR}/kernels
            ${SOURCE_DIR}/cmake ${SOURCE_DIR}/apps DESTINATION ${copy})
  step("configure twinray" 0 ${CMAKE_COMMAND} -S ${copy} -B ${WORK_DIR}/build -G ${GENERATOR}
       ${compiler_args} -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=${prefix}
       -DTWINRAY_BUILD_TESTS=OFF -DTWINRAY_BUILD_EXAMPLES=OFF)
  # The installed command is the whole of apps/twinray: about 20 translation units that
  # each instantiate the renderer, several minutes on one core. Built on every core.
  cmake_host_system_information(RESULT cores QUERY NUMBER_OF_LOGICAL_CORES)
  step("build twinray" 0 ${CMAKE_COMMAND} --build ${WORK_DIR}/build --parallel ${cores})
  step("install twinray" 0 ${CMAKE_COMMAND} --install ${WORK_DIR}/build)
  file(REMOVE_RECURSE ${copy} ${WORK_DIR}/build)

  # What must be installed, and that nothing installed points back at a tree.
  foreach(f include/twinray/twinray.hpp include/twinray/version.hpp
            include/twinray/generated/opencl_source.hpp include/twinray/device/prelude.h
            share/twinray/kernels/render.cl bin/twinray)
    if(NOT EXISTS ${prefix}/${f})
      message(FATAL_ERROR "not installed: ${f}")
    endif()
  endforeach()
  file(GLOB_RECURSE config_files ${prefix}/*/cmake/twinray/*.cmake)
  list(LENGTH config_files n)
  if(n LESS 5)
    message(FATAL_ERROR "expected twinrayConfig, -ConfigVersion and three target files, got:"
                        " ${config_files}")
  endif()
  file(GLOB_RECURSE installed ${prefix}/*)
  foreach(f ${installed})
    file(READ ${f} text)
    foreach(tree ${copy} ${WORK_DIR}/build ${SOURCE_DIR})
      string(FIND "${text}" "${tree}" at)
      if(NOT at EQUAL -1)
        message(FATAL_ERROR "${f} names ${tree}: the install is not self-contained")
      endif()
    endforeach()
  endforeach()
  # The installed command runs without the source tree: it renders the demo scene.
  step("installed twinray renders" 0 ${prefix}/bin/twinray render demo -o ${WORK_DIR}/cmd.png
       --width 64 --height 48 --backend cpu --quiet)
  if(NOT EXISTS ${WORK_DIR}/cmd.png)
    message(FATAL_ERROR "the installed twinray command wrote no image")
  endif()
  file(READ ${prefix}/include/twinray/generated/opencl_source.hpp kernel)
  string(FIND "${kernel}" "#include \"" at)
  if(NOT at EQUAL -1)
    message(FATAL_ERROR "the installed kernel still has an #include for the driver to resolve")
  endif()

  # Version and components: what find_package must accept and refuse.
  set(check ${CMAKE_COMMAND} -S ${CMAKE_CURRENT_LIST_DIR}/version_check -G ${GENERATOR}
      ${compiler_args} -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF)
  # 0.x: only the installed minor version (0.2) is accepted, older or newer.
  step("find_package(twinray 0.2) core only" 0 ${check} -B ${WORK_DIR}/vc1 -DWANT_VERSION=0.2
       "-DEXPECT_TARGETS=twinray::twinray")
  step("find_package(twinray) without components loads all" 0 ${check} -B ${WORK_DIR}/vc2
       "-DEXPECT_TARGETS=twinray::twinray;twinray::opencl;twinray::io")
  step("find_package(twinray 0.3) is refused" fail ${check} -B ${WORK_DIR}/vc3
       -DWANT_VERSION=0.3)
  step("find_package(twinray 0.1) is refused" fail ${check} -B ${WORK_DIR}/vc4
       -DWANT_VERSION=0.1)
  step("find_package(twinray 1.0) is refused" fail ${check} -B ${WORK_DIR}/vc5
       -DWANT_VERSION=1.0)
  step("find_package(twinray COMPONENTS vulkan) is refused" fail ${check} -B ${WORK_DIR}/vc6
       -DWANT_COMPONENTS=vulkan)
  string(FIND "${step_output}" "no such component" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "an unknown component must be named in the message:\n${step_output}")
  endif()

  # The consumer, with flags that contract a*b+c into FMA unless the target says no.
  set(flags "-O3 -ffp-contract=fast")
  if(HOST_PROCESSOR MATCHES "x86_64|AMD64|aarch64|arm64")
    string(APPEND flags " -march=native")
  endif()
  message(STATUS "consumer flags: ${flags}")
  step("configure consumer (find_package)" 0 ${CMAKE_COMMAND}
       -S ${CMAKE_CURRENT_LIST_DIR}/project -B ${WORK_DIR}/consumer -G ${GENERATOR}
       ${compiler_args} -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS=${flags}"
       -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF)
elseif(MODE STREQUAL "subdirectory")
  set(flag_args "")
  if(FLAGS)
    set(flag_args -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS=${FLAGS}")
  endif()
  step("configure consumer (add_subdirectory)" 0 ${CMAKE_COMMAND}
       -S ${CMAKE_CURRENT_LIST_DIR}/project -B ${WORK_DIR}/consumer -G ${GENERATOR}
       ${compiler_args} ${flag_args} -DTWINRAY_SOURCE_DIR=${SOURCE_DIR})
else()
  message(FATAL_ERROR "MODE must be installed or subdirectory")
endif()

step("build consumer" 0 ${CMAKE_COMMAND} --build ${WORK_DIR}/consumer)
foreach(scene ${SCENES})
  file(REMOVE ${WORK_DIR}/out.png)
  step("run consumer on ${scene}" 0 ${env} ${WORK_DIR}/consumer/consumer ${WORK_DIR}/${scene}
       ${WORK_DIR}/out.png)
  message(STATUS "${step_output}")
  string(FIND "${step_output}" "agree bit for bit" at)
  if(at EQUAL -1 OR NOT EXISTS ${WORK_DIR}/out.png)
    message(FATAL_ERROR "the consumer did not render ${scene} and compare both backends")
  endif()
endforeach()
# Success: the scratch folder goes (builds are large); a failure leaves it to inspect.
file(REMOVE_RECURSE ${WORK_DIR})
