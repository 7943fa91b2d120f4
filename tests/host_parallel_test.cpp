// Context::host_parallel_for: the host helper that works beside the scan's thread.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "potmap/runtime/context.hpp"
#include "runtime/host_team.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// Keeps a thread busy for about `us` microseconds, so that a run lasts long enough for the
// helper to wake and take items.
void busy_for(int us) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(us);
  while (std::chrono::steady_clock::now() < until) {
  }
}

}  // namespace

// Every item runs exactly once, and with the helper on (and a second core) some run on a
// thread other than the caller's.
TEST(HostParallel, EveryItemOnceAndTheHelperTakesPart) {
  Context& ctx = test::context();
  const auto caller = std::this_thread::get_id();
  std::set<std::thread::id> threads;
  std::mutex m;
  for (int run = 0; run < 50; ++run) {
    std::vector<std::atomic<int>> count(16);
    ctx.host_parallel_for(count.size(), [&](std::size_t i) {
      busy_for(100);
      count[i].fetch_add(1);
      std::lock_guard<std::mutex> lock(m);
      threads.insert(std::this_thread::get_id());
    });
    for (std::size_t i = 0; i < count.size(); ++i) ASSERT_EQ(count[i].load(), 1) << "item " << i;
  }
  EXPECT_EQ(threads.count(caller), 1u);
  if (std::thread::hardware_concurrency() > 1)
    EXPECT_EQ(threads.size(), 2u) << "the helper never took an item";
  else
    EXPECT_EQ(threads.size(), 1u);
  ctx.host_parallel_for(0, [](std::size_t) { FAIL() << "no item to run"; });
}

// The caller takes items from the front and the helper from the back, so each keeps its end
// of the range from one run to the next (the joint BHM's two parts stay on their cores): the
// caller's items are a prefix (empty when the helper took them all), the helper's the rest.
TEST(HostParallel, OnEveryCoreEachItemRunsOnceAndTheFirstErrorComesBack) {
  std::vector<std::atomic<int>> runs(1000);
  std::mutex m;
  std::set<std::thread::id> threads;
  detail::for_each_on_cores(runs.size(), [&](std::size_t i) {
    busy_for(20);
    runs[i].fetch_add(1);
    const std::lock_guard<std::mutex> lock(m);
    threads.insert(std::this_thread::get_id());
  });
  for (const auto& r : runs) EXPECT_EQ(r.load(), 1);
  EXPECT_EQ(threads.size() > 1, std::thread::hardware_concurrency() > 1);  // every core helps
  std::atomic<int> done{0};
  EXPECT_THROW(detail::for_each_on_cores(50,
                                         [&](std::size_t i) {
                                           done.fetch_add(1);
                                           if (i % 10 == 3) throw std::runtime_error("item");
                                         }),
               std::runtime_error);
  EXPECT_EQ(done.load(), 50);  // the other items still ran
  detail::for_each_on_cores(0, [](std::size_t) { FAIL(); });
}

TEST(HostParallel, TheCallerTakesTheFrontAndTheHelperTheBack) {
  Context& ctx = test::context();
  const auto caller = std::this_thread::get_id();
  bool helper_seen = false;
  for (int run = 0; run < 30; ++run) {
    std::vector<std::thread::id> by(12);
    ctx.host_parallel_for(by.size(), [&](std::size_t i) {
      busy_for(100);
      by[i] = std::this_thread::get_id();
    });
    // (On a loaded machine the helper may take every item before the caller takes one.)
    std::size_t k = 0;
    while (k < by.size() && by[k] == caller) ++k;
    for (std::size_t i = k; i < by.size(); ++i) {
      EXPECT_NE(by[i], caller) << "run " << run << ": item " << i << " after the helper's " << k;
      helper_seen = true;
    }
  }
  if (std::thread::hardware_concurrency() > 1) EXPECT_TRUE(helper_seen);
}

// A held helper keeps looking for runs (the joint BHM's update holds it through its fifty short
// runs): runs go on as before, with and without the hold, nested holds included, and a context
// without a helper ignores the hold.
TEST(HostParallel, AHeldHelperStillRunsEveryItemOnce) {
  Context& ctx = test::context();
  const auto caller = std::this_thread::get_id();
  bool helper_seen = false;
  ctx.hold_host_helper(true);
  ctx.hold_host_helper(true);
  // Item 0 (the caller's: it takes the front) waits up to a millisecond for item 1 to be
  // taken, which a looking helper does at once. On a loaded machine (the sanitizers' suite
  // runs two tests at a time on two cores) the helper's thread may wait for a core for a
  // while, so the runs go on until it has taken an item, for at most two seconds.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  for (int run = 0; run < 200 || (!helper_seen && std::chrono::steady_clock::now() < deadline);
       ++run) {
    std::vector<std::thread::id> by(2);
    std::vector<std::atomic<int>> count(2);
    std::atomic<bool> second_taken{false};
    ctx.host_parallel_for(2, [&](std::size_t i) {
      if (i == 1) second_taken = true;
      if (i == 0) {
        const auto wait = std::chrono::steady_clock::now() + std::chrono::milliseconds(1);
        while (!second_taken && std::chrono::steady_clock::now() < wait) {
        }
      }
      busy_for(20);
      count[i].fetch_add(1);
      by[i] = std::this_thread::get_id();
    });
    ASSERT_EQ(count[0].load(), 1);
    ASSERT_EQ(count[1].load(), 1);
    helper_seen = helper_seen || by[1] != caller;
    busy_for(100);  // host work between runs, longer than the helper's unheld look
  }
  ctx.hold_host_helper(false);
  ctx.hold_host_helper(false);
  if (std::thread::hardware_concurrency() > 1) EXPECT_TRUE(helper_seen);
  std::atomic<int> after{0};
  ctx.host_parallel_for(3, [&](std::size_t) { after.fetch_add(1); });
  EXPECT_EQ(after.load(), 3);

  ContextOptions o;
  o.host_helper = false;
  Context alone(o);
  alone.hold_host_helper(true);
  std::vector<std::size_t> order;
  alone.host_parallel_for(3, [&](std::size_t i) {
    EXPECT_EQ(std::this_thread::get_id(), caller);
    order.push_back(i);
  });
  alone.hold_host_helper(false);
  EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2}));
}

TEST(HostParallel, HelperOffRunsEveryItemOnTheCaller) {
  ContextOptions o;
  o.host_helper = false;
  Context ctx(o);
  const auto caller = std::this_thread::get_id();
  std::vector<std::size_t> order;
  ctx.host_parallel_for(8, [&](std::size_t i) {
    busy_for(50);
    EXPECT_EQ(std::this_thread::get_id(), caller);
    order.push_back(i);
  });
  EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3, 4, 5, 6, 7}));
}

// An item's exception reaches the caller after every other item ran, and the helper is free
// for the next run.
TEST(HostParallel, AnItemsExceptionIsRethrownAfterTheOthersRan) {
  Context& ctx = test::context();
  for (int run = 0; run < 20; ++run) {
    std::vector<std::atomic<int>> count(10);
    try {
      ctx.host_parallel_for(count.size(), [&](std::size_t i) {
        busy_for(50);
        count[i].fetch_add(1);
        if (i == 3 || i == 7) throw std::runtime_error("item " + std::to_string(i));
      });
      FAIL() << "expected the item's exception";
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_TRUE(what == "item 3" || what == "item 7") << what;
    }
    for (std::size_t i = 0; i < count.size(); ++i) EXPECT_EQ(count[i].load(), 1) << "item " << i;
  }
  std::atomic<int> after{0};
  ctx.host_parallel_for(4, [&](std::size_t) { after.fetch_add(1); });
  EXPECT_EQ(after.load(), 4);
}

// Two threads sharing a context (as a mapper's pipeline does): one has the helper, the other
// runs its items itself; neither waits on the other, and every item of both runs once.
TEST(HostParallel, TwoCallersAtOnceEachFinishEveryItem) {
  Context& ctx = test::context();
  std::atomic<long> total{0};
  auto caller = [&] {
    for (int run = 0; run < 200; ++run)
      ctx.host_parallel_for(5, [&](std::size_t i) {
        busy_for(20);
        total.fetch_add(long(i) + 1);
      });
  };
  std::thread a(caller), b(caller);
  a.join();
  b.join();
  EXPECT_EQ(total.load(), 2L * 200 * 15);
}
