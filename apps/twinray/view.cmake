# `twinray view` (cmd_view.cpp): the window needs SDL2 (Debian libsdl2-dev). Without
# it the subcommand is there but says the build has no viewer; nothing else in
# twinray depends on SDL2.
find_package(SDL2 CONFIG QUIET)
if(TARGET SDL2::SDL2)
  target_sources(twinray_cli PRIVATE ${CMAKE_CURRENT_LIST_DIR}/view_window.cpp
                 ${CMAKE_CURRENT_LIST_DIR}/view_controls.cpp)
  target_link_libraries(twinray_cli PRIVATE SDL2::SDL2)
  target_compile_definitions(twinray_cli PRIVATE TWINRAY_WITH_SDL2=1)
else()
  message(STATUS "twinray: SDL2 (libsdl2-dev) not found, `twinray view` has no window")
endif()
