// Work shared over threads: f(i) for i = 0..n-1, each index taken by the next free worker (the
// identification's fits, pneumo rollout's runs). Each f(i) must depend on i alone (and write only
// its own result), so the results are the same whatever `threads`.
#ifndef PNEUMATIC_PARALLEL_FOR_H_
#define PNEUMATIC_PARALLEL_FOR_H_

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <mutex>
#include <thread>
#include <vector>

namespace pneumatic {

// runs f(0) ... f(n - 1) on min(threads, n) threads (threads < 1: 1), the calling one among them
template <class F>
void ParallelFor(std::size_t n, int threads, F f) {
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t i = next++; i < n; i = next++) f(i);
  };
  const std::size_t workers = std::min(static_cast<std::size_t>(std::max(threads, 1)), std::max<std::size_t>(n, 1));
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
}

// As ParallelFor, and then(i) for i = 0..n-1 in index order, one call at a time, each as soon as
// f(0) ... f(i) have returned (on the worker that finished the last of them): the results are taken
// in the same order whatever `threads`, while the later ones are still running. f(i) must not read
// what then() writes.
template <class F, class Then>
void ParallelForInOrder(std::size_t n, int threads, F f, Then then) {
  std::mutex mutex;
  std::vector<char> finished(n, 0);
  std::size_t taken = 0;
  ParallelFor(n, threads, [&](std::size_t i) {
    f(i);
    std::lock_guard<std::mutex> lock(mutex);
    finished[i] = 1;
    while (taken < n && finished[taken]) then(taken++);
  });
}

}  // namespace pneumatic

#endif  // PNEUMATIC_PARALLEL_FOR_H_
