// The tiled raster job's writer thread: jobs run one at a time in the order given, on one
// thread, and a job's exception reaches the caller at its next submit() or wait().
#include "runtime/serial_worker.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

using potmap::detail::SerialWorker;

TEST(SerialWorker, RunsJobsInOrderOnOneThread) {
  std::vector<int> order;
  std::vector<std::thread::id> threads;
  {
    SerialWorker w;
    for (int i = 0; i < 50; ++i)
      w.submit([&, i] {
        order.push_back(i);
        threads.push_back(std::this_thread::get_id());
      });
    w.wait();
    EXPECT_EQ(order.size(), 50u);
  }
  for (int i = 0; i < 50; ++i) EXPECT_EQ(order[i], i);
  for (const std::thread::id& t : threads) EXPECT_EQ(t, threads.front());
  EXPECT_NE(threads.front(), std::this_thread::get_id());
}

TEST(SerialWorker, AFailedJobThrowsAtTheNextCallOnce) {
  SerialWorker w;
  w.submit([] { throw std::runtime_error("tile 3"); });
  EXPECT_THROW(w.submit([] {}), std::runtime_error);  // the failed job's error, not the new one
  bool ran = false;
  w.submit([&] { ran = true; });
  EXPECT_NO_THROW(w.wait());
  EXPECT_TRUE(ran);
}

TEST(SerialWorker, DestructionRunsTheJobLeft) {
  bool ran = false;
  {
    SerialWorker w;
    w.submit([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      ran = true;
    });
  }
  EXPECT_TRUE(ran);
}
