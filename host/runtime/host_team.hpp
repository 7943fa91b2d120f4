#pragma once
// A fork-join team for host work split into independent items (a scan's sectors): the calling
// thread takes items from the front, one helper thread from the back, until none is left. A
// Context owns one (Context::host_parallel_for).
//
// Why from both ends: with two items (the two halves of the joint BHM's update) each thread
// keeps its own half from one region to the next, and the data that half wrote stays in that
// core's cache; taken in turn, the halves changed cores at random, and the update ran slower
// on two cores than on one.
//
// Why not OpenMP: its idle workers spin for milliseconds after a region, on the cores PoCL's
// workers need for the launch that follows (docs/pot-scale.md, "One scan at a time"). The
// helper here looks for the next region for 50 microseconds, then sleeps.

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace potmap {
class Context;
}

namespace potmap::detail {

class HostTeam {
 public:
  /// `helper` false: every item runs on the calling thread.
  explicit HostTeam(bool helper);
  ~HostTeam();
  HostTeam(const HostTeam&) = delete;
  HostTeam& operator=(const HostTeam&) = delete;

  /// fn(i) for every i in [0, n), each once, on this thread and the helper; returns when all
  /// are done. The first exception an item throws is rethrown here (the other items still
  /// run). While another thread's run holds the helper, this thread runs every item itself.
  void run(std::size_t n, const std::function<void(std::size_t)>& fn);
  /// Context::hold_host_helper().
  void hold(bool on);

 private:
  void helper_loop();
  void take_items(bool from_back);

  std::mutex run_mutex_;  // held by the run that has the helper
  std::mutex m_;
  std::condition_variable wake_, done_;
  const std::function<void(std::size_t)>* fn_ = nullptr;
  std::size_t n_ = 0;
  // The unclaimed items [front, back): front in the high 32 bits, back in the low.
  std::atomic<std::uint64_t> range_{0};
  std::atomic<std::size_t> finished_{0};
  std::atomic<unsigned> generation_{0};
  std::atomic<int> holds_{0};  // hold(true) minus hold(false): keep looking while positive
  bool open_ = false;          // a run is taking items (the helper may join it)
  bool helper_busy_ = false, stop_ = false;
  std::exception_ptr error_;
  std::thread helper_;
};

/// ctx->host_parallel_for(n, fn), or every item on this thread when ctx is null.
void for_each_item(Context* ctx, std::size_t n, const std::function<void(std::size_t)>& fn);

/// fn(i) for every i in [0, n) on every core of the host (threads started for the call, the
/// calling thread among them; items taken in turn), for long jobs of many independent items
/// where no Context is at hand (a map's export). Returns when all are done; the first exception
/// an item throws is rethrown (the other items still run). Small n runs on this thread.
void for_each_on_cores(std::size_t n, const std::function<void(std::size_t)>& fn);

/// Context::hold_host_helper() for a scope (nothing when ctx is null).
class HelperHold {
 public:
  explicit HelperHold(Context* ctx);
  ~HelperHold();
  HelperHold(const HelperHold&) = delete;
  HelperHold& operator=(const HelperHold&) = delete;

 private:
  Context* ctx_;
};

}  // namespace potmap::detail
