// twinray's one exception type. Its kind tells a program which exit status to use
// (docs/command-line.md): bad input 2, backend unavailable 3, run-time failure 1.
#pragma once

#include <stdexcept>
#include <string>

namespace twinray {

enum class ErrorKind {
  InvalidInput,        // the scene, camera or options are wrong; nothing was rendered
  BackendUnavailable,  // the requested backend (or device, or double support) is not there
  RuntimeFailure,      // rendering or writing failed while running
};

// Thrown by every twinray function that can fail; what() is a complete sentence for a
// user, naming the file, value or device concerned.
class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }

 private:
  ErrorKind kind_;
};

inline Error invalid_input(const std::string& message) {
  return Error(ErrorKind::InvalidInput, message);
}

}  // namespace twinray
