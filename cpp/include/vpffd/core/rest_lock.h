#pragma once
/// @file rest_lock.h
/// The lock between a deformer's frames and the moves of its rest mesh.
///
/// Frames read the rest state (embedding, processing order, fans, rest volumes) and
/// run side by side; a move (set_rest_vertices, set_rest_offsets) rewrites that state
/// and must run alone. std::shared_mutex would do, but glibc's rwlock behind it
/// prefers readers: three threads drawing frames back to back can hold it shared for
/// ever and starve the thread that moves the object. This lock prefers the writer: a
/// waiting move holds back frames that have not started, waits for those in flight,
/// runs, and then lets the frames that waited go first. Readers must not take it twice on one thread (a
/// waiting writer between the two would deadlock them): deformers take it once, at
/// their public entry points.

#include <condition_variable>
#include <mutex>

namespace vpffd {

/// Writer-preferring, phase-fair shared lock: meets the SharedMutex requirements used
/// by std::shared_lock and std::unique_lock (lock_shared/unlock_shared, lock/unlock).
/// When a move ends, the frames that waited for it go first, before the next move:
/// a thread that moves the rest mesh back to back cannot starve the frames either.
class RestLock {
 public:
  RestLock() = default;
  RestLock(const RestLock&) = delete;
  RestLock& operator=(const RestLock&) = delete;

  void lock_shared() {
    std::unique_lock<std::mutex> g(m_);
    if (writing_ || (writers_waiting_ > 0 && admitted_ == 0)) {
      ++readers_waiting_;
      readers_cv_.wait(g, [&] { return !writing_ && (writers_waiting_ == 0 || admitted_ > 0); });
      --readers_waiting_;
    }
    if (admitted_ > 0) --admitted_;
    ++readers_;
  }
  void unlock_shared() {
    std::lock_guard<std::mutex> g(m_);
    if (--readers_ == 0 && admitted_ == 0 && writers_waiting_ > 0) writer_cv_.notify_one();
  }
  void lock() {
    std::unique_lock<std::mutex> g(m_);
    ++writers_waiting_;
    writer_cv_.wait(g, [&] { return !writing_ && readers_ == 0 && admitted_ == 0; });
    --writers_waiting_;
    writing_ = true;
  }
  void unlock() {
    std::lock_guard<std::mutex> g(m_);
    writing_ = false;
    // The frames that waited for this move are let in ahead of any waiting move.
    admitted_ = readers_waiting_;
    if (readers_waiting_ > 0)
      readers_cv_.notify_all();
    else if (writers_waiting_ > 0)
      writer_cv_.notify_one();
  }

 private:
  std::mutex m_;
  std::condition_variable readers_cv_, writer_cv_;
  int readers_ = 0;          ///< frames holding the lock
  int readers_waiting_ = 0;  ///< frames waiting for it
  int admitted_ = 0;         ///< waiting frames let in ahead of waiting moves
  int writers_waiting_ = 0;
  bool writing_ = false;
};

}  // namespace vpffd
