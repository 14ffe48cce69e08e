#pragma once

// A process-wide memo of values that take long to compute and depend only on
// their key (calibration draws, model correlations): at most `capacity`
// entries, all dropped when full, so a hit never depends on what was kept
// before. Thread-safe; a value is shared, never copied under the lock.

#include <map>
#include <memory>
#include <mutex>
#include <utility>

namespace imuqual::allan {

template <typename Key, typename Value>
class BoundedMemo {
 public:
  explicit BoundedMemo(size_t capacity) : capacity_(capacity) {}

  std::shared_ptr<const Value> Find(const Key& key) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = entries_.find(key);
    return it == entries_.end() ? nullptr : it->second;
  }

  // Keeps `value` under `key` (an entry already there stays) and returns it.
  std::shared_ptr<const Value> Put(Key key, Value value) {
    auto shared = std::make_shared<const Value>(std::move(value));
    std::lock_guard<std::mutex> lock(mutex_);
    if (entries_.size() >= capacity_) entries_.clear();
    return entries_.emplace(std::move(key), std::move(shared)).first->second;
  }

 private:
  const size_t capacity_;
  mutable std::mutex mutex_;
  std::map<Key, std::shared_ptr<const Value>> entries_;
};

}  // namespace imuqual::allan
