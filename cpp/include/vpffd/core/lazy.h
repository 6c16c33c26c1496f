#pragma once
/// @file lazy.h
/// A value computed once, on its first read, by whichever thread reads it first.
///
/// The rest state of a deformer (frame/rest_state.h) is immutable once published, but
/// some of what it derives is read by few frames (renumbered faces, the face matrix,
/// the rest volumes): building those eagerly on every move of the rest mesh would cost
/// every move what only some frames need. Lazy makes such a member part of the
/// immutable state: it is the same value whenever and by whomever it is read, and it
/// is built at most once (concurrent first readers wait for the one that builds it).

#include <atomic>
#include <mutex>
#include <utility>

namespace vpffd {

template <class T>
class Lazy {
 public:
  Lazy() = default;
  /// A value known from the start (built eagerly): get() returns it without building.
  explicit Lazy(T value) : value_(std::move(value)), known_(true) {}
  Lazy(const Lazy&) = delete;
  Lazy& operator=(const Lazy&) = delete;

  /// The value, built by make() on the first call. A make() that throws leaves the
  /// value unknown (the next read builds it again). make() must not read this Lazy.
  template <class Make>
  const T& get(Make&& make) const {
    if (known_.load(std::memory_order_acquire)) return value_;
    std::call_once(once_, [&] {
      value_ = make();
      known_.store(true, std::memory_order_release);
    });
    return value_;
  }
  /// Whether the value is built (get() then costs nothing).
  bool known() const { return known_.load(std::memory_order_acquire); }
  /// The value if it is built, else null.
  const T* if_known() const { return known() ? &value_ : nullptr; }

 private:
  mutable std::once_flag once_;
  mutable T value_{};
  mutable std::atomic<bool> known_{false};
};

}  // namespace vpffd
