// mocap-search under an MPI launcher (mpi_search.hpp).
#include "mpi_search.hpp"

#include <mpi.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <thread>

#include "mocap/common/io/collection_manifest.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/collection_search.hpp"

namespace mocap::mpi {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// How often the ranks exchange their thresholds while they search, and how
// often a rank polls an exchange in flight (MPI_Test) meanwhile: short
// enough that a query reached late by a rank finds the others' scores,
// long enough that the exchange costs a rank well under 1 % of a core.
constexpr auto kExchangePeriod = std::chrono::milliseconds(5);
constexpr auto kPollPeriod = std::chrono::microseconds(500);
// Bytes per message when rank 0 gathers the outcomes (MPI counts are int).
constexpr std::size_t kChunkBytes = std::size_t{1} << 30;

void check(int rc, const char* what) {
  if (rc != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + what + " failed");
}

std::uint64_t node_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0
             ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page)
             : 0;
}

double peak_rss_MB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // kB on Linux
}

void atomic_min(std::atomic<double>& a, double v) {
  double cur = a.load(std::memory_order_relaxed);
  while (v < cur && !a.compare_exchange_weak(cur, v, std::memory_order_relaxed)) {
  }
}

// Rank 0 receives every rank's bytes (its own included), in rank order.
std::vector<std::string> gather_bytes(const Session& s, const std::string& mine) {
  std::vector<std::string> all;
  if (s.rank() != 0) {
    std::uint64_t n = mine.size();
    check(MPI_Send(&n, 1, MPI_UINT64_T, 0, 0, MPI_COMM_WORLD), "MPI_Send");
    for (std::size_t at = 0; at < mine.size(); at += kChunkBytes)
      check(MPI_Send(mine.data() + at, static_cast<int>(std::min(kChunkBytes, mine.size() - at)),
                     MPI_BYTE, 0, 1, MPI_COMM_WORLD),
            "MPI_Send");
    return all;
  }
  all.push_back(mine);
  for (int r = 1; r < s.size(); ++r) {
    std::uint64_t n = 0;
    check(MPI_Recv(&n, 1, MPI_UINT64_T, r, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE), "MPI_Recv");
    std::string bytes(n, '\0');
    for (std::size_t at = 0; at < n; at += kChunkBytes)
      check(
          MPI_Recv(bytes.data() + at, static_cast<int>(std::min<std::size_t>(kChunkBytes, n - at)),
                   MPI_BYTE, r, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE),
          "MPI_Recv");
    all.push_back(std::move(bytes));
  }
  return all;
}

// Per entry and pair, the r-th best score this rank has found (`found`) and
// the least that any rank had found at the last exchange (`shared`), +inf
// where none; entry i's pairs at [i * stride, i * stride + stride).
struct Thresholds {
  std::size_t stride = 1;
  std::vector<std::atomic<double>> found, shared;
  explicit Thresholds(const std::vector<BatchEntry>& batch) {
    for (const BatchEntry& e : batch)
      if (e.query && e.query->frames.size() > 1)
        stride = std::max(stride, e.query->frames.size() - 1);
    found = std::vector<std::atomic<double>>(batch.size() * stride);
    shared = std::vector<std::atomic<double>>(batch.size() * stride);
    for (auto& a : found) a.store(kInf);
    for (auto& a : shared) a.store(kInf);
  }
  ShardHooks hooks(std::size_t first) {
    ShardHooks h;
    h.first = first;
    h.reached = [this](std::size_t i, const std::vector<double>& r) {
      for (std::size_t p = 0; p < r.size() && p < stride; ++p)
        atomic_min(found[i * stride + p], r[p]);
    };
    h.shared = [this](std::size_t i) {
      std::vector<double> out(stride);
      for (std::size_t p = 0; p < stride; ++p)
        out[p] = shared[i * stride + p].load(std::memory_order_relaxed);
      return out;
    };
    return h;
  }
};

// Runs `work` on a thread of its own while this (the MPI) thread exchanges
// the thresholds with the other ranks, until every rank's work is done.
// Every rank makes the same number of all-reduces: the last value of each
// is -1 on a rank still working and 0 on one done, so the minimum is 0
// exactly when all are done, and all ranks stop after that same exchange.
void run_exchanging(Thresholds& t, const std::function<void()>& work) {
  std::atomic<bool> finished{false};
  std::thread worker([&] {
    work();
    finished.store(true);
  });
  const std::size_t n = t.found.size();
  std::vector<double> send(n + 1), recv(n + 1);
  for (;;) {
    const bool done_here = finished.load();
    for (std::size_t k = 0; k < n; ++k) send[k] = t.found[k].load(std::memory_order_relaxed);
    send[n] = done_here ? 0.0 : -1.0;
    MPI_Request request;
    check(MPI_Iallreduce(send.data(), recv.data(), static_cast<int>(n + 1), MPI_DOUBLE, MPI_MIN,
                         MPI_COMM_WORLD, &request),
          "MPI_Iallreduce");
    for (int flag = 0;;) {
      check(MPI_Test(&request, &flag, MPI_STATUS_IGNORE), "MPI_Test");
      if (flag) break;
      std::this_thread::sleep_for(kPollPeriod);
    }
    for (std::size_t k = 0; k < n; ++k) t.shared[k].store(recv[k], std::memory_order_relaxed);
    if (recv[n] == 0.0) break;
    std::this_thread::sleep_for(kExchangePeriod);
  }
  worker.join();
}

}  // namespace

bool launched_by_mpi() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
    if (std::getenv(v)) return true;
  return false;
}

Session::Session(int* argc, char*** argv) {
  int provided = 0;
  check(MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &node);
  MPI_Comm_size(node, &ranks_per_node_);
  MPI_Comm_free(&node);
}

Session::~Session() {
  MPI_Finalize();
}

std::vector<std::string> Session::errors(const std::string& mine) const {
  const std::vector<std::string> all = all_gather(mine.substr(0, std::size_t{1} << 20));
  std::vector<std::string> out;
  for (std::size_t r = 0; r < all.size(); ++r)
    if (!all[r].empty()) out.push_back("rank " + std::to_string(r) + ": " + all[r]);
  return out;
}

std::vector<std::string> Session::all_gather(const std::string& mine) const {
  // The lengths in 64 bits, so that every rank alike refuses a total that
  // an MPI count (int) cannot hold, rather than one rank leaving the others
  // waiting in the collective.
  const std::uint64_t mine_length = mine.size();
  std::vector<std::uint64_t> lengths64(static_cast<std::size_t>(size_));
  check(MPI_Allgather(&mine_length, 1, MPI_UINT64_T, lengths64.data(), 1, MPI_UINT64_T,
                      MPI_COMM_WORLD),
        "MPI_Allgather");
  std::uint64_t sum = 0;
  for (const std::uint64_t n : lengths64) sum += n;
  if (sum > static_cast<std::uint64_t>(std::numeric_limits<int>::max()))
    throw std::runtime_error("MPI: all_gather: more bytes than an MPI count holds");
  const int length = static_cast<int>(mine_length);
  std::vector<int> lengths(lengths64.size()), offsets(lengths.size());
  int total = 0;
  for (std::size_t r = 0; r < lengths.size(); ++r) {
    lengths[r] = static_cast<int>(lengths64[r]);
    offsets[r] = total;
    total += lengths[r];
  }
  std::string all(static_cast<std::size_t>(total), '\0');
  check(MPI_Allgatherv(mine.data(), length, MPI_CHAR, all.data(), lengths.data(), offsets.data(),
                       MPI_CHAR, MPI_COMM_WORLD),
        "MPI_Allgatherv");
  std::vector<std::string> out;
  for (std::size_t r = 0; r < lengths.size(); ++r)
    out.push_back(
        all.substr(static_cast<std::size_t>(offsets[r]), static_cast<std::size_t>(lengths[r])));
  return out;
}

double Session::max(double value) const {
  double out = value;
  check(MPI_Allreduce(&value, &out, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD), "MPI_Allreduce");
  return out;
}

void on_every_rank(const Session& session, const std::function<void()>& step) {
  std::string error;
  try {
    step();
  } catch (const std::exception& e) {
    error = e.what();
    if (error.empty()) error = "failed";
  }
  const std::vector<std::string> errors = session.errors(error);
  if (errors.empty()) return;
  std::string text;
  for (const std::string& e : errors) text += (text.empty() ? "" : "\n") + e;
  throw RankFailure(text);
}

DistributedResult run_distributed_batch(
    const Session& session, const std::filesystem::path& index,
    const std::vector<BatchEntry>& batch, const SearchOptions& options,
    std::optional<Distribution> requested,
    const std::function<void(std::size_t, std::size_t)>& progress) {
  const bool collection = is_collection_manifest(index);
  if (requested == Distribution::shards && !collection)
    throw InputError(index.string(), 0,
                     "--distribute shards needs a collection manifest (mocap-index build "
                     "--shards); a plain index is searched with --distribute queries");
  CollectionManifest manifest;
  on_every_rank(session, [&] {
    if (collection) manifest = read_collection_manifest(index);
  });
  DistributedResult result;
  std::uint64_t frames = 0;
  for (const CollectionShard& s : manifest.shards) frames += s.frames;
  result.distribution =
      requested ? *requested
                : choose_distribution(frames, collection ? manifest.shards.size() : 1,
                                      static_cast<std::size_t>(session.size()),
                                      static_cast<std::size_t>(session.ranks_per_node()),
                                      node_memory_bytes());
  const auto ranks = static_cast<std::size_t>(session.size());
  const auto rank = static_cast<std::size_t>(session.rank());
  const bool by_shards = result.distribution == Distribution::shards;

  // The indexes this rank opens, checked (every rank alike) before any query runs.
  std::vector<ShardSource> sources;
  on_every_rank(session, [&] {
    if (!collection) {
      sources.push_back({index, index.string(), std::nullopt, 0});
      return;
    }
    std::vector<std::size_t> mine;
    if (by_shards) mine = assign_shards(manifest, ranks)[rank];
    CollectionManifest checked;
    for (std::size_t k = 0; k < manifest.shards.size(); ++k)
      if (!by_shards || std::find(mine.begin(), mine.end(), k) != mine.end())
        checked.shards.push_back(manifest.shards[k]);
    if (const auto problems = collection_shard_problems(index, checked); !problems.empty())
      throw InputError(index.string(), 0, problems.front());
    sources = manifest_shards(index, manifest, by_shards ? &mine : nullptr);
  });
  result.shards_here = sources.size();
  // Dealt shards: each rank holds part of the collection, and query filters
  // are checked against the union of every rank's label values.
  LabelValues labels;
  const bool dealt = by_shards && ranks > 1;
  if (dealt) {
    std::string here;
    on_every_rank(session, [&] { here = encode_label_values(shard_label_values(sources)); });
    for (const std::string& bytes : session.all_gather(here))
      for (const auto& [key, values] : decode_label_values(bytes))
        labels[key].insert(values.begin(), values.end());
  }

  // This rank's entries: all of them (shards), or every K-th (queries).
  std::vector<BatchEntry> mine;
  std::vector<std::size_t> positions;
  for (std::size_t i = 0; i < batch.size(); ++i)
    if (by_shards || i % ranks == rank) {
      mine.push_back(batch[i]);
      positions.push_back(i);
    }
  const auto progress_here = rank == 0 ? progress : std::function<void(std::size_t, std::size_t)>{};
  std::vector<QueryOutcome> answered;
  if (dealt) {
    Thresholds thresholds(mine);
    ShardHooks hooks = thresholds.hooks(rank * mine.size() / ranks);
    hooks.labels = &labels;
    std::string error;
    run_exchanging(thresholds, [&] {
      try {
        if (!sources.empty())
          answered = search_shards(sources, mine, options, hooks, progress_here);
      } catch (const std::exception& e) {
        error = e.what();
      }
    });
    on_every_rank(session, [&] {
      if (!error.empty()) throw std::runtime_error(error);
    });
  } else {
    on_every_rank(session, [&] {
      if (!sources.empty()) answered = search_shards(sources, mine, options, {}, progress_here);
    });
  }

  // Rank 0 gathers and merges; the entries come back in batch order.
  const std::vector<std::string> bytes = gather_bytes(session, encode_outcomes(answered));
  const double rss = peak_rss_MB();
  result.peak_rss_max_MB = session.max(rss);
  result.peak_rss_min_MB = -session.max(-rss);
  if (rank != 0) return result;
  if (!by_shards) {
    result.outcomes.resize(batch.size());
    for (std::size_t r = 0; r < bytes.size(); ++r) {
      std::vector<QueryOutcome> part = decode_outcomes(bytes[r]);
      for (std::size_t j = 0; j < part.size(); ++j)
        result.outcomes[r + j * ranks] = std::move(part[j]);
    }
    return result;
  }
  std::vector<std::vector<QueryOutcome>> per_rank;
  for (const std::string& b : bytes)
    if (std::vector<QueryOutcome> part = decode_outcomes(b); !part.empty())
      per_rank.push_back(std::move(part));
  result.outcomes =
      merge_shard_outcomes(per_rank, std::vector<std::size_t>(per_rank.size(), 0), batch);
  return result;
}

}  // namespace mocap::mpi
