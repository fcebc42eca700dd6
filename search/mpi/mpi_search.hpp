#pragma once
// mocap-search under an MPI launcher (docs/search.md "Many machines: MPI"):
//
//   mpirun -np K mocap-search --index COLLECTION.json --queries Q.jsonl --out R.jsonl
//          [--distribute auto|shards|queries]
//
// Every rank runs the same command line. Under `shards` each rank searches
// the shards dealt to it (assign_shards) for every query with its TBB
// threads, starting the batch at entry rank x n / K so that the ranks reach
// each query at different times; a thread of MPI calls on each rank's main
// thread exchanges, every few milliseconds, the r-th best score each rank has
// found per query and pair (one non-blocking all-reduce with MPI_MIN), which
// every rank then prunes against (shared_ceiling). Under `queries` each rank
// opens the whole index or collection and answers every K-th query. Rank 0
// gathers the outcomes, merges them (merge_shard_outcomes) and alone writes
// the output, in query order: the results equal one process's.
//
// Failures never hang the job: each step that can fail on one rank (reading
// the batch, checking the output path, checking and opening shards, a search
// that throws) is followed by a collective in which every rank reports its
// error or none; when any rank failed, every rank learns every message
// ("rank k: ...") and all return together.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "mocap/search/distributed.hpp"
#include "mocap/search/search.hpp"

namespace mocap::mpi {

/// True when this process was started by an MPI launcher (Open MPI's
/// OMPI_COMM_WORLD_SIZE, PMIx's PMIX_RANK or the PMI's PMI_SIZE in the
/// environment). A program started otherwise never initialises MPI.
bool launched_by_mpi();

/// MPI for the lifetime of the object: MPI_Init_thread (MPI_THREAD_FUNNELED:
/// only the thread that made the session calls MPI), MPI_Finalize at
/// destruction. At most one per process.
class Session {
 public:
  Session(int* argc, char*** argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Ranks on this rank's node (MPI_COMM_TYPE_SHARED).
  int ranks_per_node() const { return ranks_per_node_; }

  /// A collective: every rank passes its own error ("" for none); every rank
  /// gets the errors of all, as "rank k: message", in rank order (empty
  /// when no rank failed).
  std::vector<std::string> errors(const std::string& mine) const;
  /// A collective: every rank passes its bytes; every rank gets all ranks'
  /// bytes, in rank order.
  std::vector<std::string> all_gather(const std::string& mine) const;
  /// A collective: the maximum over the ranks.
  double max(double value) const;

 private:
  int rank_ = 0, size_ = 1, ranks_per_node_ = 1;
};

/// Thrown (on every rank alike) when some rank failed: what() lists each
/// failed rank's message, one per line.
struct RankFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Calls `step`; its InputError or other exception becomes this rank's
/// error for Session::errors. Throws RankFailure on every rank when any
/// rank's step failed.
void on_every_rank(const Session& session, const std::function<void()>& step);

struct DistributedResult {
  /// Rank 0: every entry's outcome, in batch order (merged). Other ranks: empty.
  std::vector<QueryOutcome> outcomes;
  Distribution distribution = Distribution::queries;
  /// Indexes (shards, or the one index) this rank opened.
  std::size_t shards_here = 0;
  /// Peak resident memory of the ranks (getrusage), least and greatest, MB.
  double peak_rss_min_MB = 0.0, peak_rss_max_MB = 0.0;
};

/// Answers `batch` on all ranks (a collective). `index` is a collection
/// manifest or a plain index; `requested` the distribution asked for
/// (nullopt: choose_distribution; shards needs a manifest). `progress` is
/// called on rank 0 alone, with rank 0's own share of the work. Throws
/// RankFailure as on_every_rank, and InputError (on every rank alike) for
/// --distribute shards over a plain index.
DistributedResult run_distributed_batch(
    const Session& session, const std::filesystem::path& index,
    const std::vector<BatchEntry>& batch, const SearchOptions& options,
    std::optional<Distribution> requested,
    const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace mocap::mpi
