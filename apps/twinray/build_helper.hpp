// The `twinray` command as its own OpenCL build helper (opencl::set_build_helper): a
// block program new to the machine is built into the disk caches by a second, detached
// `twinray` process, started with the hidden first argument --opencl-build-helper once
// the first frame is rendered; the first process does not wait for it.
#pragma once

namespace twinray_cli {

// Whether this process was started as the build helper (argv[1] is
// --opencl-build-helper).
bool is_build_helper(int argc, char** argv);

// The helper's work: "--opencl-build-helper --device N --options O --kernel K" builds
// that program (opencl::ProgramCache::build_for_later_processes). Exit status 0 when it
// reached the caches, 1 when not, 2 for another command line.
int run_build_helper(int argc, char** argv);

// Names this program (/proc/self/exe) as the OpenCL backend's build helper. Without
// OpenCL, or where the program's path cannot be read, it does nothing: nothing is then
// built in the background.
void register_build_helper();

}  // namespace twinray_cli
