// The host fork-join team (host_team.hpp).
#include "host_team.hpp"

#include <algorithm>
#include <chrono>
#include <vector>

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

void HostTeam::take_items(bool from_back) {
  for (;;) {
    std::uint64_t r = range_.load();
    std::size_t i = 0;
    for (;;) {
      const std::uint64_t front = r >> 32, back = r & 0xffffffffu;
      if (front >= back) return;
      i = static_cast<std::size_t>(from_back ? back - 1 : front);
      const std::uint64_t claimed =
          from_back ? (front << 32) | (back - 1) : ((front + 1) << 32) | back;
      if (range_.compare_exchange_weak(r, claimed)) break;
    }
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
    while (
        generation_.load(std::memory_order_acquire) == seen &&
        (holds_.load(std::memory_order_relaxed) > 0 || std::chrono::steady_clock::now() < until)) {
    }
    std::unique_lock<std::mutex> lock(m_);
    wake_.wait(lock, [&] { return stop_ || generation_.load() != seen || holds_.load() > 0; });
    if (stop_) return;
    const unsigned g = generation_.load();
    if (g == seen) continue;  // woken by a hold: look for the next run
    seen = g;
    if (!open_) continue;  // the caller finished that run alone
    helper_busy_ = true;
    lock.unlock();
    take_items(true);
    lock.lock();
    helper_busy_ = false;
    lock.unlock();
    done_.notify_one();
  }
}

void HostTeam::run(std::size_t n, const std::function<void(std::size_t)>& fn) {
  std::unique_lock<std::mutex> mine(run_mutex_, std::try_to_lock);
  if (!helper_.joinable() || n < 2 || n > 0xffffffffu || !mine.owns_lock()) {
    for_each_item(nullptr, n, fn);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(m_);
    fn_ = &fn;
    n_ = n;
    range_.store(std::uint64_t(n));
    finished_.store(0);
    error_ = nullptr;
    open_ = true;
    generation_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_one();
  take_items(false);
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

void HostTeam::hold(bool on) {
  if (!helper_.joinable()) return;
  if (on) {
    // A sleeping helper wakes to look. Through m_: it tests holds_ under m_, so the notify
    // cannot fall between its test and its sleep.
    holds_.fetch_add(1);
    { std::lock_guard<std::mutex> lock(m_); }
    wake_.notify_one();
  } else {
    holds_.fetch_sub(1);
  }
}

HelperHold::HelperHold(Context* ctx) : ctx_(ctx) {
  if (ctx_) ctx_->hold_host_helper(true);
}

HelperHold::~HelperHold() {
  if (ctx_) ctx_->hold_host_helper(false);
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

void for_each_on_cores(std::size_t n, const std::function<void(std::size_t)>& fn) {
  const std::size_t threads =
      std::min<std::size_t>({n, std::max(1u, std::thread::hardware_concurrency()), 64});
  std::atomic<std::size_t> next{0};
  std::mutex m;
  std::exception_ptr first;
  auto work = [&] {
    for (std::size_t i; (i = next.fetch_add(1)) < n;) try {
        fn(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(m);
        if (!first) first = std::current_exception();
      }
  };
  std::vector<std::thread> team;
  for (std::size_t t = 1; t < threads; ++t) team.emplace_back(work);
  work();
  for (std::thread& t : team) t.join();
  if (first) std::rethrow_exception(first);
}

}  // namespace potmap::detail
