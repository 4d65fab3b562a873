// The re-entrancy tests' harness: the same jobs on two threads at once, each thread on scratch of
// its own, every result compared with the one-thread result.
#pragma once

#include <array>
#include <thread>

namespace swerve::testing {

// Runs every job `passes` times on each of two threads at once (the second thread in the opposite
// order, so the two threads' jobs overlap in every combination). Each thread makes its scratch
// with make_scratch(); matches(scratch, job) runs one job on it and says whether the result is the
// one-thread result, bit for bit. Returns each thread's mismatches.
template <typename MakeScratch, typename Matches>
std::array<int, 2> mismatches_on_two_threads(int jobs, int passes, const MakeScratch& make_scratch,
                                             const Matches& matches) {
  std::array<int, 2> mismatches{0, 0};
  const auto worker = [&](int id) {
    auto scratch = make_scratch();
    for (int pass = 0; pass < passes; ++pass) {
      for (int i = 0; i < jobs; ++i) {
        if (!matches(scratch, id == 1 ? jobs - 1 - i : i)) ++mismatches[static_cast<std::size_t>(id)];
      }
    }
  };
  std::thread first(worker, 0), second(worker, 1);
  first.join();
  second.join();
  return mismatches;
}

}  // namespace swerve::testing
