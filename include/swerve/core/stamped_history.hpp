// A fixed-capacity history of time-stamped records, newest first: the commands a controller sent or
// the measurements it took, kept for estimators that look back over them (fault detection, the
// grip estimate, a lost encoder's stand-in). No allocation: the real-time path pushes into it.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>

namespace swerve {

// `Record` carries its time as a member `double t` (s). Once full, a push overwrites the oldest.
template <typename Record, int Capacity>
class StampedHistory {
  static_assert(Capacity > 0, "StampedHistory: Capacity must be positive");

 public:
  // The record for time `t`, now the newest; the caller fills in the rest of it.
  Record& push(double t) noexcept {
    newest_ = (newest_ + 1) % Capacity;
    count_ = count_ < Capacity ? count_ + 1 : Capacity;
    Record& record = records_[static_cast<std::size_t>(newest_)];
    record.t = t;
    return record;
  }
  int size() const noexcept { return count_; }
  bool empty() const noexcept { return count_ == 0; }
  // The record `back` pushes before the newest (0: the newest); back in [0, size()).
  const Record& back(int back) const noexcept {
    return records_[static_cast<std::size_t>((newest_ - back + Capacity) % Capacity)];
  }
  const Record& newest() const noexcept { return back(0); }
  // How many pushes before the newest lies the newest record stamped within `tolerance` (s) of `t`
  // (back()'s argument), or -1 if none is.
  int find(double t, double tolerance) const noexcept {
    for (int k = 0; k < count_; ++k) {
      if (std::abs(back(k).t - t) <= tolerance) return k;
    }
    return -1;
  }
  void clear() noexcept {
    count_ = 0;
    newest_ = -1;
  }

 private:
  std::array<Record, static_cast<std::size_t>(Capacity)> records_{};
  int count_ = 0, newest_ = -1;
};

}  // namespace swerve
