#pragma once
// One thread that runs one job at a time beside its caller, for as long as it lives: a pipeline
// of depth one (the caller prepares job k + 1 while the worker runs job k). The thread persists
// across jobs, so what a job keeps in thread_local buffers (the GeoTIFF block encoder's) stays
// allocated and warm instead of being faulted in again for every job, as a thread per job
// (std::async) would.

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace potmap::detail {

class SerialWorker {
 public:
  SerialWorker();
  ~SerialWorker();
  SerialWorker(const SerialWorker&) = delete;
  SerialWorker& operator=(const SerialWorker&) = delete;

  /// Waits for the job before (rethrowing its exception), then starts `job`.
  void submit(std::function<void()> job);

  /// Waits for the job running, if any; rethrows its exception.
  void wait();

 private:
  void loop();

  std::mutex m_;
  std::condition_variable cv_;
  std::function<void()> job_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::thread thread_;  // last: started once the members it uses are
};

}  // namespace potmap::detail
