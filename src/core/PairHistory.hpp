#pragma once
// The history of contacts in transit: what a contact keeps from step to step (a tangential
// spring, an impact speed, a torque spring, ...) while the neighbour list is rebuilt, while
// particles migrate between ranks, and in snapshots. One row per (owner id, partner id), with
// the columns the contact module declared when it was made. The carriers (HaloExchange::
// migrate, the snapshot writer and reader) move whole rows and never name a column: a law with
// history of its own declares its columns and packs its rows, and nothing else changes. In a
// snapshot each column is the dataset contacts/<name> (a column a snapshot lacks reads as zeros).
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

namespace cassini {

class PairHistory {
 public:
  struct Column {
    std::string name;
    int width;   // doubles
    int offset;  // in a row
  };

  // A named column of `width` doubles per contact; its offset in a row. Declared once, when the
  // modules are made (before the first rebuild).
  int declare(const std::string& name, int width) {
    for (const Column& c : columns_)
      if (c.name == name) throw std::logic_error("contact history column '" + name + "' declared twice");
    if (!owner.empty()) throw std::logic_error("contact history column '" + name + "' declared after rows exist");
    columns_.push_back({name, width, width_});
    width_ += width;
    return columns_.back().offset;
  }
  const std::vector<Column>& columns() const { return columns_; }
  int width() const { return width_; }  // doubles per row

  // The same columns, no rows.
  PairHistory columns_only() const {
    PairHistory h;
    h.columns_ = columns_;
    h.width_ = width_;
    return h;
  }

  std::size_t size() const { return owner.size(); }
  void clear() {
    owner.clear();
    partner.clear();
    values.clear();
  }
  // A new row of zeros; its values (valid until the next add).
  double* add(std::int64_t owner_id, std::int64_t partner_id) {
    owner.push_back(owner_id);
    partner.push_back(partner_id);
    values.resize(values.size() + width_, 0.0);
    return row(owner.size() - 1);
  }
  double* row(std::size_t k) { return values.data() + k * width_; }
  const double* row(std::size_t k) const { return values.data() + k * width_; }

  // Rows in (owner, partner) order, and the rows of one owner as [first, last).
  void sort() {
    std::vector<std::uint32_t> order(size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
      return owner[a] < owner[b] || (owner[a] == owner[b] && partner[a] < partner[b]);
    });
    PairHistory sorted = columns_only();
    sorted.owner.reserve(size());
    sorted.partner.reserve(size());
    sorted.values.reserve(values.size());
    for (const std::uint32_t k : order) std::copy_n(row(k), width_, sorted.add(owner[k], partner[k]));
    *this = std::move(sorted);
  }
  std::pair<std::size_t, std::size_t> rows_of(std::int64_t owner_id) const {
    const auto [b, e] = std::equal_range(owner.begin(), owner.end(), owner_id);
    return {std::size_t(b - owner.begin()), std::size_t(e - owner.begin())};
  }

  std::vector<std::int64_t> owner, partner;
  std::vector<double> values;  // width() per row

 private:
  std::vector<Column> columns_;
  int width_ = 0;
};

}  // namespace cassini
