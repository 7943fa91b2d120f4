// The host fork-join team (host_team.hpp).
#include "host_team.hpp"

#include <chrono>

#include "potmap/runtime/context.hpp"

namespace potmap::detail {

namespace {

// How long the helper looks for the next region before it sleeps: one scan's host stages follow
// each other within tens of microseconds; between them lie device launches of milliseconds.
constexpr auto kSpin = std::chrono::microseconds(50);

}  // namespace

HostTeam::HostTeam(bool helper) {
  if (helper) helper_ = std::thread([this] { helper_loop(); });
}

HostTeam::~HostTeam() {
  if (!helper_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
  }
  wake_.notify_one();
  helper_.join();
}

void HostTeam::take_items() {
  for (;;) {
    const std::size_t i = next_.fetch_add(1);
    if (i >= n_) return;
    try {
      (*fn_)(i);
    } catch (...) {
      std::lock_guard<std::mutex> lock(m_);
      if (!error_) error_ = std::current_exception();
    }
    finished_.fetch_add(1);
  }
}

void HostTeam::helper_loop() {
  unsigned seen = 0;
  for (;;) {
    const auto until = std::chrono::steady_clock::now() + kSpin;
    while (generation_.load(std::memory_order_acquire) == seen &&
           std::chrono::steady_clock::now() < until) {
    }
    std::unique_lock<std::mutex> lock(m_);
    wake_.wait(lock, [&] { return stop_ || generation_.load() != seen; });
    if (stop_) return;
    seen = generation_.load();
    if (!open_) continue;  // the caller finished that run alone
    helper_busy_ = true;
    lock.unlock();
    take_items();
    lock.lock();
    helper_busy_ = false;
    lock.unlock();
    done_.notify_one();
  }
}

void HostTeam::run(std::size_t n, const std::function<void(std::size_t)>& fn) {
  std::unique_lock<std::mutex> mine(run_mutex_, std::try_to_lock);
  if (!helper_.joinable() || n < 2 || !mine.owns_lock()) {
    for_each_item(nullptr, n, fn);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(m_);
    fn_ = &fn;
    n_ = n;
    next_.store(0);
    finished_.store(0);
    error_ = nullptr;
    open_ = true;
    generation_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_one();
  take_items();
  std::unique_lock<std::mutex> lock(m_);
  // A helper that has not joined by now will not: the run closes under the lock it takes to
  // join.
  done_.wait(lock, [&] { return finished_.load() == n_ && !helper_busy_; });
  open_ = false;
  std::exception_ptr e = error_;
  error_ = nullptr;
  fn_ = nullptr;
  lock.unlock();
  if (e) std::rethrow_exception(e);
}

void for_each_item(Context* ctx, std::size_t n, const std::function<void(std::size_t)>& fn) {
  if (ctx) {
    ctx->host_parallel_for(n, fn);
    return;
  }
  // As a run with the helper behaves: every item runs, then the first exception is rethrown.
  std::exception_ptr first;
  for (std::size_t i = 0; i < n; ++i) try {
      fn(i);
    } catch (...) {
      if (!first) first = std::current_exception();
    }
  if (first) std::rethrow_exception(first);
}

}  // namespace potmap::detail
