// write_file_atomically(): an output file is either complete or absent. The bytes go to
// a temporary file in the same folder, are flushed to the disk, and the temporary is
// renamed over the target; on any failure it is removed and the earlier file stays as
// it was (core/atomic_file.hpp, which this throws for).
#pragma once

#include <cstring>
#include <string>
#include <vector>

#include <twinray/core/atomic_file.hpp>
#include <twinray/core/error.hpp>

namespace twinray {
namespace io {

// The temporary files' names (core/atomic_file.hpp): ".tmp-HOST-PID", and which are
// left over by a process of this host that is gone.
using twinray::is_abandoned_temporary;
using twinray::is_temporary;
using twinray::temporary_suffix;

// Throws Error(RuntimeFailure) "PATH: what: reason" (e.g. "No space left on device").
// Any thread may call it; the temporary is named after the host and the process, so
// two threads of one process must not write the same path at the same time.
inline void write_file_atomically(const std::string& path, const void* data, size_t size) {
  WriteFailure failure;
  if (!try_write_file_atomically(path, data, size, temporary_suffix(), true, &failure))
    throw Error(ErrorKind::RuntimeFailure,
                path + ": " + failure.what + ": " + std::strerror(failure.error));
}

inline void write_file_atomically(const std::string& path,
                                  const std::vector<unsigned char>& bytes) {
  write_file_atomically(path, bytes.data(), bytes.size());
}

}  // namespace io
}  // namespace twinray
