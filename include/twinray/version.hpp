// The version of twinray these headers are: TWINRAY_VERSION_MAJOR, _MINOR, _PATCH as
// integers for #if, TWINRAY_VERSION_STRING for messages. The CMake package has the same
// version (find_package(twinray 0.2) accepts 0.2.* while twinray is 0.x; CHANGELOG.md).
#pragma once

#define TWINRAY_VERSION_MAJOR 0
#define TWINRAY_VERSION_MINOR 2
#define TWINRAY_VERSION_PATCH 0
#define TWINRAY_VERSION_STRING "0.2.0"
