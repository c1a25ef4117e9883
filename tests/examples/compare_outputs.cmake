# Runs PROGRAM with --backend cpu and --backend opencl, writing OUT-cpu.EXT and
# OUT-opencl.EXT, and fails unless both runs succeed and the files are equal byte for byte.
foreach(backend cpu opencl)
  file(REMOVE "${OUT}-${backend}.${EXT}")
  execute_process(COMMAND "${PROGRAM}" --backend ${backend} --output "${OUT}-${backend}.${EXT}"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message(STATUS "${backend}: ${out}${err}")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${PROGRAM} --backend ${backend} failed (${rc}): ${err}")
  endif()
endforeach()
file(SIZE "${OUT}-cpu.${EXT}" size)
if(size LESS 1000)
  message(FATAL_ERROR "${OUT}-cpu.${EXT} holds only ${size} bytes")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files "${OUT}-cpu.${EXT}" "${OUT}-opencl.${EXT}"
                RESULT_VARIABLE differ)
if(NOT differ EQUAL 0)
  message(FATAL_ERROR "${OUT}-cpu.${EXT} and ${OUT}-opencl.${EXT} differ")
endif()
message(STATUS "the same ${size} bytes from both backends")
