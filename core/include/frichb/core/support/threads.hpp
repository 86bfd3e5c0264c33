// Work spread over a few threads for the span of one call (the contact traces of an evaluation,
// the harmonics of a Jacobian product).
#pragma once

#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace frichb::core {

// Runs work(i) for every i in [0, threads) at once: i = 0 on the calling thread, each other i
// on a thread of its own, and returns when all have ended. The first exception thrown (in the
// order of i) is rethrown then. `threads` <= 1 runs work(0) on the calling thread. `work` must
// be safe to call concurrently for different i.
template <typename Work>
void run_on_threads(std::size_t threads, const Work& work) {
  if (threads <= 1) {
    work(std::size_t{0});
    return;
  }
  std::vector<std::exception_ptr> failures(threads);
  const auto guarded = [&](std::size_t i) {
    try {
      work(i);
    } catch (...) {
      failures[i] = std::current_exception();
    }
  };
  {
    std::vector<std::jthread> pool;
    for (std::size_t i = 1; i < threads; ++i) pool.emplace_back(guarded, i);
    guarded(0);
  }  // joined
  for (const auto& failure : failures)
    if (failure) std::rethrow_exception(failure);
}

}  // namespace frichb::core
