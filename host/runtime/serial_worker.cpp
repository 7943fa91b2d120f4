// SerialWorker (serial_worker.hpp). Out of line: a thread started from a constructor defined in
// the header would give the thread's state type, and its typeinfo, the linkage of an inline
// function's lambda, exported from the shared library as a weak symbol.
#include "runtime/serial_worker.hpp"

#include <utility>

namespace potmap::detail {

SerialWorker::SerialWorker() : thread_([this] { loop(); }) {}

SerialWorker::~SerialWorker() {
  {
    std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void SerialWorker::submit(std::function<void()> job) {
  wait();
  {
    std::lock_guard<std::mutex> lock(m_);
    job_ = std::move(job);
  }
  cv_.notify_all();
}

void SerialWorker::wait() {
  std::unique_lock<std::mutex> lock(m_);
  cv_.wait(lock, [this] { return !job_; });
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void SerialWorker::loop() {
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

}  // namespace potmap::detail
