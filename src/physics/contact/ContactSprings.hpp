#pragma once
// The tangential (and rolling) springs of a neighbour list's contacts, stored only where there
// is a contact: each list entry holds the number of its spring's slot, or kNone. In a gas one
// entry in eight touches and an owned pair keeps one spring for its two entries, so this is
// 4 B per entry where a spring per entry took 24 (48 with rolling resistance); a contact's
// spring sits in a small dense pool rather than in a list-sized array touched at random.
#include <cstdint>
#include <vector>

#include "core/Vec3.hpp"

namespace cassini {

class ContactSprings {
 public:
  static constexpr std::uint32_t kNone = 0xffffffffu;

  // Every entry without a spring; rolling: a torque spring with each tangential one.
  void reset(std::size_t entries, bool rolling) {
    if (entries > slot_.capacity()) slot_.reserve(entries + entries / 8);
    slot_.assign(entries, kNone);
    xi_.clear();
    roll_.clear();
    free_.clear();
    rolling_ = rolling;
  }
  std::size_t entries() const { return slot_.size(); }
  std::uint32_t* slots() { return slot_.data(); }
  std::uint32_t slot(std::size_t k) const { return slot_[k]; }

  // A zero spring for entry k if it has none; its slot.
  std::uint32_t hold(std::uint32_t& slot) {
    if (slot != kNone) return slot;
    if (!free_.empty()) {
      slot = free_.back();
      free_.pop_back();
      xi_[slot].setZero();
      if (rolling_) roll_[slot].setZero();
    } else {
      slot = static_cast<std::uint32_t>(xi_.size());
      xi_.push_back(Vec3::Zero());
      if (rolling_) roll_.push_back(Vec3::Zero());
    }
    return slot;
  }
  // The contact is over: its springs are forgotten.
  void release(std::uint32_t& slot) {
    if (slot == kNone) return;
    free_.push_back(slot);
    slot = kNone;
  }
  // Valid until the next hold().
  Vec3& xi(std::uint32_t slot) { return xi_[slot]; }
  Vec3& roll(std::uint32_t slot) { return roll_[slot]; }
  const Vec3& xi(std::uint32_t slot) const { return xi_[slot]; }
  const Vec3& roll(std::uint32_t slot) const { return roll_[slot]; }

 private:
  std::vector<std::uint32_t> slot_;  // per list entry
  std::vector<Vec3> xi_, roll_;      // per slot
  std::vector<std::uint32_t> free_;  // slots released
  bool rolling_ = false;
};

}  // namespace cassini
