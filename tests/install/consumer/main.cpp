// best_match INDEX.h5 QUERY.json: the best partial motion for the query's first pair.
#include <cstdio>
#include <stdexcept>

#include "mocap/common/io/index.hpp"
#include "mocap/search/search.hpp"

int main(int argc, char** argv) {
  if (argc != 3) return std::fprintf(stderr, "usage: best_match INDEX.h5 QUERY.json\n"), 2;
  try {
    const mocap::Index index = mocap::Index::open(argv[1]);
    const mocap::SearchEngine engine(index);  // tables built once; run() is thread-safe
    const mocap::BatchEntry entry = mocap::read_single_query(argv[2]).at(0);
    if (!entry.query) throw std::runtime_error(entry.error);
    const mocap::QueryOutcome outcome = engine.run(*entry.query, mocap::SearchOptions{});
    if (outcome.error) throw std::runtime_error(*outcome.error);
    const mocap::SearchResult& best = outcome.pairs.at(0).results.at(0);
    std::printf("%s %zu-%zu %.6f J\n", best.clip.c_str(), best.start_frame, best.end_frame,
                best.score_J);
  } catch (const std::exception& e) {  // mocap::InputError reads "file:line: what"
    return std::fprintf(stderr, "best_match: %s\n", e.what()), 2;
  }
}
