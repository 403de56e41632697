// A small multi-producer queue: DDS callbacks push, the node's own thread pops and decides.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>

namespace dh {

template <class E>
class EventQueue {
 public:
  void push(E e) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(std::move(e));
    }
    cv_.notify_one();
  }
  /// Waits up to `timeout` for an event; nullopt on timeout.
  std::optional<E> pop(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    if (!cv_.wait_for(lock, timeout, [&] { return !queue_.empty(); })) return std::nullopt;
    E e = std::move(queue_.front());
    queue_.pop_front();
    return e;
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<E> queue_;
};

}  // namespace dh
