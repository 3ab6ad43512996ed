#include "engine/output/serial_writer.hpp"

#include <stdexcept>
#include <utility>

namespace yarnsim::output {

SerialWriter::SerialWriter(std::size_t capacity)
    : capacity_(capacity), thread_([this] { loop(); }) {
  if (capacity == 0) {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    changed_.notify_all();
    thread_.join();
    throw std::invalid_argument("SerialWriter: capacity must be at least 1");
  }
}

SerialWriter::~SerialWriter() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable())
    thread_.join();
}

void SerialWriter::post(std::function<void()> task) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return queue_.size() < capacity_ || error_; });
  if (error_)
    std::rethrow_exception(error_);
  queue_.push_back(std::move(task));
  lock.unlock();
  changed_.notify_all();
}

void SerialWriter::drain() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return queue_.empty() && !busy_; });
  if (error_)
    std::rethrow_exception(error_);
}

void SerialWriter::loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return !queue_.empty() || stop_; });
    if (queue_.empty())
      return; // stopped with nothing left
    std::function<void()> task = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    lock.unlock();
    changed_.notify_all(); // room in the queue
    std::exception_ptr error;
    try {
      task();
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    busy_ = false;
    if (error && !error_) {
      error_ = error;
      queue_.clear(); // the files may not be in order any more: nothing else is written
    }
    changed_.notify_all();
  }
}

} // namespace yarnsim::output
