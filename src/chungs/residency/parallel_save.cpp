#include "chungs/residency/parallel_save.hpp"

#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

namespace chungs {

void save_chunks_in_parallel(ChunkStore& store, const std::vector<ChunkId>& ids,
                             const std::function<void(size_t, GaussianBlock&)>& produce, int threads) {
  if (threads <= 1 || ids.size() <= 1) {
    GaussianBlock b;
    for (size_t k = 0; k < ids.size(); ++k) {
      produce(k, b);
      store.save(ids[k], b);
    }
    return;
  }
  std::mutex m;
  std::condition_variable ready, room;
  std::deque<std::pair<size_t, GaussianBlock>> queue;
  bool done = false;
  std::exception_ptr error;
  const size_t max_queued = 2 * size_t(threads);
  auto writer = [&] {
    for (;;) {
      std::pair<size_t, GaussianBlock> job;
      {
        std::unique_lock lock(m);
        ready.wait(lock, [&] { return !queue.empty() || done || error; });
        if (error || queue.empty()) return;
        job = std::move(queue.front());
        queue.pop_front();
      }
      room.notify_one();
      try {
        store.save(ids[job.first], job.second);
      } catch (...) {
        std::lock_guard lock(m);
        if (!error) error = std::current_exception();
        ready.notify_all();
        room.notify_all();
        return;
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(writer);
  try {
    for (size_t k = 0; k < ids.size(); ++k) {
      GaussianBlock b;
      produce(k, b);
      std::unique_lock lock(m);
      room.wait(lock, [&] { return queue.size() < max_queued || error; });
      if (error) break;
      queue.emplace_back(k, std::move(b));
      ready.notify_one();
    }
  } catch (...) {
    std::lock_guard lock(m);
    if (!error) error = std::current_exception();
  }
  {
    std::lock_guard lock(m);
    done = true;
  }
  ready.notify_all();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace chungs
