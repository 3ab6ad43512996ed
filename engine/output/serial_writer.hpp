#pragma once
// The serial writer of a run's output (issue #7: output overlapped with the next step): the
// solver thread hands each completed increment's output over as a task and goes on with the next
// increment, while one thread of its own runs the tasks one after another in the order they came
// (HDF5 step, XDMF, CSV rows, checkpoint). Tasks hold copies of what they write, so the files get
// the same bytes as when the solver wrote them itself.
//
// The thread is not one of oneTBB's (--threads counts the threads that compute): it spends its
// time in file I/O. At most `capacity` tasks wait; post() then waits for the writer, so a slow
// disk holds the solver back instead of filling the memory.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace yarnsim::output {

class SerialWriter {
public:
  /// capacity: tasks that may wait behind the running one, >= 1.
  explicit SerialWriter(std::size_t capacity = 2);
  SerialWriter(const SerialWriter&) = delete;
  SerialWriter& operator=(const SerialWriter&) = delete;
  /// Runs what is queued, then stops the thread; never throws (an error is lost: call drain()).
  ~SerialWriter();

  /// Queues task behind the others; waits while capacity tasks wait. Throws the exception of the
  /// task that failed, if one did: after a failure no further task runs, since the files may not
  /// be in order any more.
  void post(std::function<void()> task);

  /// Waits until every task posted has run (or was dropped after a failure). Throws the
  /// exception of the task that failed, if one did.
  void drain();

private:
  void loop();

  std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> queue_;
  bool busy_ = false; ///< a task is running
  bool stop_ = false;
  std::exception_ptr error_; ///< of the first task that failed
  std::thread thread_;       ///< last: starts on the members above
};

} // namespace yarnsim::output
