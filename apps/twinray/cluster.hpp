// The processes of one `twinray` job: a single process, or the ranks of an MPI job
// started by mpirun or srun (docs/distributed.md).
//
// A subcommand that can run on many ranks is written once, as a sequence of steps that
// every rank takes together; with one process each step is a plain call:
//   1. share_from_rank0(): rank 0 checks its own arguments and reads the scene file;
//      the bytes reach every rank (MPI_Bcast).
//   2. agree(): every rank prepares its part (parses the scene, applies the options) and
//      derives a key of everything that decides the pixels; the keys must be equal.
//   3. share_work(): rank 0 hands out frames or tiles one at a time to whichever rank
//      asks next, renders some itself on a second thread, and collects the results.
// A step that fails on any rank fails on all of them: rank 0 throws an Error that names
// the rank, the other ranks throw QuietExit with the same exit status. Anything else
// that escapes a rank ends the whole job (finish() with a non-zero status).
//
// MPI is used only when twinray was built with it (TWINRAY_WITH_MPI, set by CMake when
// find_package(MPI) finds it) and the process was started by an MPI launcher.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

namespace twinray_cli {

// Ends a rank other than 0 with `status` and no message: rank 0 reports the failure.
struct QuietExit {
  int status;
};

namespace cluster {

// Joins the MPI job when the process was started by mpirun, srun or another MPI
// launcher. A twinray built without MPI that is started as one of several ranks throws
// Error(InvalidInput): every rank would render the whole job and write the same files.
void start(int* argc, char*** argv);

// Leaves the job. `status` 0, or a failure that every rank took part in, finalizes MPI;
// any other failure aborts every rank with `status` (MPI_Abort).
void finish(int status);

// Says that the failure this rank is about to return is one that every rank meets
// alike (a bad command line), so that finish() lets the ranks end together.
void fail_alike();

int rank();
int size();
inline bool distributed() {
  return size() > 1;
}
// How this process starts its lines on stderr: "twinray: ", or "twinray[rank 2]: " on
// a rank other than 0.
std::string message_prefix();

// Runs `read` on rank 0 and returns its bytes on every rank (MPI_Bcast). When it
// throws, every rank fails (see above).
std::string share_from_rank0(const std::function<std::string()>& read);

// Runs `setup` on every rank. It returns a key of what must be the same on all ranks;
// agree() returns when every rank succeeded with the same key. Otherwise it fails on
// every rank, with a message that names the first rank that failed, or the first whose
// key differs from rank 0's (`mismatch` says what the key covers).
void agree(const std::function<std::string()>& setup, const std::string& mismatch);

// Renders one item (a frame, a tile) and returns its bytes.
using WorkFn = std::function<std::string(long long item)>;
// Takes one item's bytes on rank 0's main thread, in the order they arrive.
using CollectFn = std::function<void(long long item, std::string&& bytes)>;

struct WorkSummary {
  std::vector<long long> items_per_rank;  // how many items each rank rendered
  bool interrupted = false;               // *interrupted became true: not every item is done
};

// Hands out `items` one at a time to whichever rank asks next, rank 0 included: rank 0's
// main thread coordinates (MPI_Iprobe, and a 1 ms sleep when nothing came, so it does
// not spin on a core that renders) while a second thread renders rank 0's share. A
// rank's next item is sent before its result is collected, so a slow collect (encoding
// a frame) does not hold it up. With one process, the items are rendered and collected
// in order on the calling thread. Rank 0 returns once every item is collected; the
// other ranks return when rank 0 tells them to stop. If `work` or `collect` throws on
// any rank, the ranks finish the items they hold, then every rank fails.
WorkSummary share_work(const std::vector<long long>& items, const WorkFn& work,
                       const CollectFn& collect, const std::atomic<bool>* interrupted);

// "2 ranks (frames per rank: 5, 4)": the closing summary's words for a job of several
// ranks; "" for one process.
std::string ranks_note(const WorkSummary& summary, const std::string& what);

}  // namespace cluster
}  // namespace twinray_cli
