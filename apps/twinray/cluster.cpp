// The steps of cluster.hpp, over MPI when twinray is built with it (TWINRAY_WITH_MPI)
// and started by an MPI launcher, and as plain calls in one process otherwise.
//
// Between rank 0 and a worker rank, every message is a header of two 64-bit integers
// with the message's tag, followed, when the header's size is not 0, by that many bytes
// in chunks of at most 1 GiB (tag kData), so that no count exceeds an int:
//   worker -> 0   kReady  {0, 0}            the worker wants its first item
//                 kResult {item, size}      an item's bytes; the worker wants the next
//                 kFail   {status, size}    the item failed: exit status, message
//   0 -> worker   kWork   {item, 0}         render this item
//                 kStop   {status, 0}       no more items; status != 0: the job failed
#include "cluster.hpp"

#include <chrono>
#include <cstdlib>
#include <deque>
#include <exception>
#include <mutex>
#include <sstream>
#include <thread>
#include <utility>

#include <twinray/core/error.hpp>

#include "cli_common.hpp"

#ifdef TWINRAY_WITH_MPI
#include <mpi.h>
#endif

namespace twinray_cli {
namespace cluster {
namespace {

int g_rank = 0;
int g_size = 1;
// Set once no rank waits on this one any more: a step failed on every rank alike, or
// the last step (share_work) is over. The ranks then finalize MPI together, whatever
// the exit status; otherwise a failure aborts the job (a rank that returns 0 has taken
// every step).
bool g_ranks_released = false;
// The number of ranks an MPI launcher announces in the environment, 0 when none does:
// Open MPI's mpirun, MPICH's Hydra and srun --mpi=pmi2 (PMI_SIZE), and the tasks of an
// srun job step. A batch script itself is not a step of several tasks, so twinray run
// there directly is one process. A PMIx launcher that names the rank but not the size
// counts as 1: MPI is initialised and tells the size.
int launcher_size() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS"}) {
    const char* value = std::getenv(name);
    if (value && *value) return std::atoi(value);
  }
  const char* pmix = std::getenv("PMIX_RANK");
  return pmix && *pmix ? 1 : 0;
}

// One process: every item in order, on the calling thread.
WorkSummary share_work_here(const std::vector<long long>& items, const WorkFn& work,
                            const CollectFn& collect, const std::atomic<bool>* interrupted) {
  WorkSummary summary;
  summary.items_per_rank.assign(1, 0);
  for (long long item : items) {
    if (interrupted && interrupted->load()) {
      summary.interrupted = true;
      break;
    }
    collect(item, work(item));
    ++summary.items_per_rank[0];
  }
  return summary;
}

#ifdef TWINRAY_WITH_MPI

twinray::ErrorKind kind_of(int status) {
  if (status == kExitBadInput) return twinray::ErrorKind::InvalidInput;
  if (status == kExitBackendUnavailable) return twinray::ErrorKind::BackendUnavailable;
  return twinray::ErrorKind::RuntimeFailure;
}

// The exit status and message of the exception being handled.
std::pair<int, std::string> describe(std::exception_ptr e) {
  try {
    std::rethrow_exception(e);
  } catch (const twinray::Error& error) {
    return {exit_status(error.kind()), error.what()};
  } catch (const QuietExit& quiet) {
    return {quiet.status, ""};
  } catch (const std::bad_alloc&) {
    return {kExitRuntimeFailure, "out of memory"};
  } catch (const std::exception& error) {
    return {kExitRuntimeFailure, error.what()};
  } catch (...) {
    return {kExitRuntimeFailure, "unknown failure"};
  }
}

enum Tag { kReady = 1, kResult, kFail, kWork, kStop, kData };
constexpr long long kChunk = 1ll << 30;
bool g_mpi = false;

// `value` is the item or the exit status; `size` the bytes that follow.
struct Header {
  long long value = 0, size = 0;
};

void send(int to, Tag tag, Header h, const std::string& bytes = {}) {
  h.size = static_cast<long long>(bytes.size());
  MPI_Send(&h, 2, MPI_LONG_LONG, to, tag, MPI_COMM_WORLD);
  for (long long at = 0; at < h.size; at += kChunk)
    MPI_Send(bytes.data() + at, static_cast<int>(std::min(kChunk, h.size - at)), MPI_BYTE, to,
             kData, MPI_COMM_WORLD);
}

// Receives the header of a message of `tag` from `from` (MPI_ANY_TAG: any), then its
// bytes; returns the tag.
int receive(int from, int tag, Header* h, std::string* bytes) {
  MPI_Status status;
  MPI_Recv(h, 2, MPI_LONG_LONG, from, tag, MPI_COMM_WORLD, &status);
  bytes->assign(static_cast<size_t>(h->size), '\0');
  for (long long at = 0; at < h->size; at += kChunk)
    MPI_Recv(&(*bytes)[static_cast<size_t>(at)], static_cast<int>(std::min(kChunk, h->size - at)),
             MPI_BYTE, status.MPI_SOURCE, kData, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return status.MPI_TAG;
}

void broadcast(std::string* bytes) {
  long long size = static_cast<long long>(bytes->size());
  MPI_Bcast(&size, 1, MPI_LONG_LONG, 0, MPI_COMM_WORLD);
  bytes->resize(static_cast<size_t>(size));
  for (long long at = 0; at < size; at += kChunk)
    MPI_Bcast(&(*bytes)[static_cast<size_t>(at)], static_cast<int>(std::min(kChunk, size - at)),
              MPI_BYTE, 0, MPI_COMM_WORLD);
}

// Every rank's string, on rank 0 (empty elsewhere).
std::vector<std::string> gather(const std::string& mine) {
  int length = static_cast<int>(mine.size());
  std::vector<int> lengths(static_cast<size_t>(g_size)), offsets(static_cast<size_t>(g_size));
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::string all;
  if (g_rank == 0) {
    long long total = 0;
    for (int r = 0; r < g_size; ++r) offsets[r] = static_cast<int>(total), total += lengths[r];
    all.resize(static_cast<size_t>(total));
  }
  MPI_Gatherv(mine.data(), length, MPI_CHAR, &all[0], lengths.data(), offsets.data(), MPI_CHAR, 0,
              MPI_COMM_WORLD);
  std::vector<std::string> out;
  if (g_rank == 0)
    for (int r = 0; r < g_size; ++r) out.push_back(all.substr(offsets[r], lengths[r]));
  return out;
}

// Every rank learns rank 0's verdict; a failure is thrown on all of them.
void settle(int status, const std::string& message, std::exception_ptr own) {
  MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (status == 0) return;
  g_ranks_released = true;
  if (g_rank != 0) throw QuietExit{status};
  if (own) std::rethrow_exception(own);
  throw twinray::Error(kind_of(status), message);
}

WorkSummary coordinate(const std::vector<long long>& items, const WorkFn& work,
                       const CollectFn& collect, const std::atomic<bool>* interrupted) {
  const long long n = static_cast<long long>(items.size());
  WorkSummary summary;
  summary.items_per_rank.assign(static_cast<size_t>(g_size), 0);
  std::atomic<long long> next{0};
  std::atomic<bool> stop_local{false};

  // Rank 0's own share, on a second thread; results wait in `done` for the main thread.
  std::mutex mutex;
  std::deque<std::pair<long long, std::string>> done;
  std::exception_ptr local_error;
  bool local_finished = false;
  // Rank 0 takes the first item itself, so that it always renders (its backend names
  // the device in the closing summary).
  std::thread local([&, first = next.fetch_add(1)] {
    for (long long i = first; i < n && !stop_local.load(); i = next.fetch_add(1)) {
      try {
        std::string bytes = work(items[static_cast<size_t>(i)]);
        std::lock_guard<std::mutex> lock(mutex);
        done.emplace_back(items[static_cast<size_t>(i)], std::move(bytes));
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        local_error = std::current_exception();
        break;
      }
    }
    std::lock_guard<std::mutex> lock(mutex);
    local_finished = true;
  });

  int fail_status = 0;
  std::string fail_message;
  std::exception_ptr fail_own;  // rank 0's own failure, rethrown as it was
  auto fail = [&](int status, std::string message, std::exception_ptr own) {
    if (fail_status != 0) return;
    fail_status = status == 0 ? kExitRuntimeFailure : status;
    fail_message = std::move(message);
    fail_own = own;
    stop_local.store(true);
  };
  int stopped = 1;  // rank 0 itself
  long long collected = 0;
  auto take = [&](int rank, long long item, std::string&& bytes) {
    if (fail_status != 0) return;
    try {
      collect(item, std::move(bytes));
      ++summary.items_per_rank[static_cast<size_t>(rank)];
      ++collected;
    } catch (...) {
      std::exception_ptr e = std::current_exception();
      auto [status, message] = describe(e);
      fail(status, message, e);
    }
  };
  // The worker's next item, or the order to stop.
  auto give = [&](int rank) {
    const long long i = fail_status == 0 ? next.fetch_add(1) : n;
    if (i < n) {
      send(rank, kWork, {items[static_cast<size_t>(i)], 0});
    } else {
      send(rank, kStop, {fail_status, 0});
      ++stopped;
    }
  };

  bool finished_local = false;
  while (true) {
    if (interrupted && interrupted->load()) {
      summary.interrupted = true;
      break;
    }
    bool idle = true;
    int flag = 0;
    MPI_Status status;
    MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
    if (flag && status.MPI_TAG != kData) {
      idle = false;
      const int rank = status.MPI_SOURCE;
      Header h;
      std::string bytes;
      const int tag = receive(rank, status.MPI_TAG, &h, &bytes);
      if (tag == kResult) {
        give(rank);  // first, so that the worker renders while this rank collects
        take(rank, h.value, std::move(bytes));
      } else if (tag == kFail) {
        fail(static_cast<int>(h.value), "rank " + std::to_string(rank) + ": " + bytes, nullptr);
        give(rank);
      } else {
        give(rank);
      }
    }
    std::deque<std::pair<long long, std::string>> mine;
    std::exception_ptr error;
    {
      std::lock_guard<std::mutex> lock(mutex);
      mine.swap(done);
      error = local_error;
      local_error = nullptr;
      finished_local = local_finished;
    }
    for (auto& [item, bytes] : mine) take(0, item, std::move(bytes)), idle = false;
    if (error) {
      auto [s, message] = describe(error);
      fail(s, message, error);
    }
    if (finished_local && mine.empty() && stopped == g_size) break;
    if (idle) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  local.join();
  g_ranks_released = !summary.interrupted;
  if (fail_status != 0) {
    if (fail_own) std::rethrow_exception(fail_own);
    throw twinray::Error(kind_of(fail_status), fail_message);
  }
  return summary;
}

WorkSummary serve(const WorkFn& work) {
  send(0, kReady, {});
  while (true) {
    Header h;
    std::string bytes;
    const int tag = receive(0, MPI_ANY_TAG, &h, &bytes);
    if (tag == kStop) {
      g_ranks_released = true;
      if (h.value != 0) throw QuietExit{static_cast<int>(h.value)};
      return {};
    }
    std::string result;
    std::pair<int, std::string> failure{0, ""};
    try {
      result = work(h.value);
    } catch (...) {
      failure = describe(std::current_exception());
    }
    if (failure.first == 0)
      send(0, kResult, {h.value, 0}, result);
    else
      send(0, kFail, {failure.first, 0}, failure.second);
  }
}

#endif  // TWINRAY_WITH_MPI

}  // namespace

void start(int* argc, char*** argv) {
  const int announced = launcher_size();
#ifdef TWINRAY_WITH_MPI
  if (announced > 0) {
    // Only the main thread calls MPI; rendering threads never do.
    int provided = 0;
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    g_mpi = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    if (g_size == 1 && announced > 1)
      throw twinray::invalid_input(
          "started as one of " + std::to_string(announced) +
          " ranks, but the MPI library sees only this process: the launcher and the MPI "
          "library do not match (under Slurm, try srun --mpi=pmix)");
  }
#else
  (void)argc, (void)argv;
  if (announced > 1)
    throw twinray::invalid_input(
        "started as one of " + std::to_string(announced) +
        " ranks by an MPI launcher, but this twinray was built without MPI: every rank "
        "would render the whole job; install libopenmpi-dev and build again "
        "(docs/distributed.md)");
#endif
}

void finish(int status) {
#ifdef TWINRAY_WITH_MPI
  if (!g_mpi) return;
  g_mpi = false;
  if (g_ranks_released || status == 0)
    MPI_Finalize();
  else
    MPI_Abort(MPI_COMM_WORLD, status == 0 ? kExitRuntimeFailure : status);
#else
  (void)status;
#endif
}

void fail_alike() {
  g_ranks_released = true;
}

int rank() {
  return g_rank;
}

std::string message_prefix() {
  return g_rank == 0 ? "twinray: " : "twinray[rank " + std::to_string(g_rank) + "]: ";
}
int size() {
  return g_size;
}

std::string share_from_rank0(const std::function<std::string()>& read) {
#ifdef TWINRAY_WITH_MPI
  if (g_size > 1) {
    std::string bytes;
    std::pair<int, std::string> failure{0, ""};
    std::exception_ptr own;
    if (g_rank == 0) {
      try {
        bytes = read();
      } catch (...) {
        own = std::current_exception();
        failure = describe(own);
      }
    }
    settle(failure.first, failure.second, own);
    broadcast(&bytes);
    return bytes;
  }
#endif
  return read();
}

void agree(const std::function<std::string()>& setup, const std::string& mismatch) {
#ifdef TWINRAY_WITH_MPI
  if (g_size > 1) {
    std::string key;
    std::pair<int, std::string> failure{0, ""};
    std::exception_ptr own;
    try {
      key = setup();
    } catch (...) {
      own = std::current_exception();
      failure = describe(own);
    }
    // Each rank sends "status\nkey\nmessage"; rank 0 finds the first rank that failed
    // or whose key differs from its own.
    std::ostringstream mine;
    mine << failure.first << '\n' << key << '\n' << failure.second;
    std::vector<std::string> all = gather(mine.str());
    int status = 0, failed_rank = -1;
    std::string message;
    if (g_rank == 0) {
      for (int r = 0; r < g_size && status == 0; ++r) {
        const std::string& text = all[static_cast<size_t>(r)];
        const size_t first = text.find('\n'), second = text.find('\n', first + 1);
        const int rank_status = std::atoi(text.substr(0, first).c_str());
        const std::string rank_key = text.substr(first + 1, second - first - 1);
        const std::string rest = text.substr(second + 1);
        if (rank_status != 0) {
          status = rank_status, failed_rank = r;
          message = r == 0 ? rest : "rank " + std::to_string(r) + ": " + rest;
        } else if (rank_key != key) {
          status = kExitBadInput;
          message = "rank " + std::to_string(r) + " derived the key " + rank_key + ", rank 0 " +
                    key + ": " + mismatch +
                    " differ between the ranks; give every rank the same scene file and options";
        }
      }
    }
    settle(status, message, failed_rank == 0 ? own : nullptr);
    return;
  }
#endif
  (void)mismatch;
  setup();
}

WorkSummary share_work(const std::vector<long long>& items, const WorkFn& work,
                       const CollectFn& collect, const std::atomic<bool>* interrupted) {
#ifdef TWINRAY_WITH_MPI
  if (g_size > 1) return g_rank == 0 ? coordinate(items, work, collect, interrupted) : serve(work);
#endif
  return share_work_here(items, work, collect, interrupted);
}

std::string ranks_note(const WorkSummary& summary, const std::string& what) {
  if (summary.items_per_rank.size() < 2) return "";
  std::ostringstream s;
  s << summary.items_per_rank.size() << " ranks (" << what << " per rank: ";
  for (size_t r = 0; r < summary.items_per_rank.size(); ++r)
    s << (r ? ", " : "") << summary.items_per_rank[r];
  s << ")";
  return s.str();
}

}  // namespace cluster
}  // namespace twinray_cli
