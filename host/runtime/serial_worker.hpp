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
#include <utility>

namespace potmap::detail {

class SerialWorker {
 public:
  SerialWorker() : thread_([this] { loop(); }) {}
  ~SerialWorker() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  SerialWorker(const SerialWorker&) = delete;
  SerialWorker& operator=(const SerialWorker&) = delete;

  /// Waits for the job before (rethrowing its exception), then starts `job`.
  void submit(std::function<void()> job) {
    wait();
    {
      std::lock_guard<std::mutex> lock(m_);
      job_ = std::move(job);
    }
    cv_.notify_all();
  }

  /// Waits for the job running, if any; rethrows its exception.
  void wait() {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [this] { return !job_; });
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(m_);
    for (;;) {
      cv_.wait(lock, [this] { return stop_ || job_; });
      if (!job_) return;  // stopped with nothing left to run
      lock.unlock();
      std::exception_ptr error;
      try {
        job_();
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      job_ = nullptr;
      error_ = error;
      cv_.notify_all();
    }
  }

  std::mutex m_;
  std::condition_variable cv_;
  std::function<void()> job_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::thread thread_;  // last: started once the members it uses are
};

}  // namespace potmap::detail
