#include "core/ParticleStore.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace cassini {

namespace {

template <class T>
T zero() {
  if constexpr (std::is_same_v<T, Vec3>) return Vec3::Zero();
  else return T{0};
}

// One entry as doubles in a migration buffer (ids bit-exactly, small integers as values).
template <class T>
void put(std::vector<double>& buf, const T& value) {
  if constexpr (std::is_same_v<T, Vec3>) {
    buf.insert(buf.end(), value.data(), value.data() + 3);
  } else if constexpr (std::is_same_v<T, std::int64_t>) {
    double d;
    static_assert(sizeof d == sizeof value);
    std::memcpy(&d, &value, sizeof d);
    buf.push_back(d);
  } else {
    buf.push_back(static_cast<double>(value));
  }
}
template <class T>
std::size_t get(const std::vector<double>& buf, std::size_t o, T& value) {
  if constexpr (std::is_same_v<T, Vec3>) {
    value = Vec3(buf[o], buf[o + 1], buf[o + 2]);
    return o + 3;
  } else if constexpr (std::is_same_v<T, std::int64_t>) {
    std::memcpy(&value, &buf[o], sizeof value);
    return o + 1;
  } else {
    value = static_cast<T>(buf[o]);
    return o + 1;
  }
}
template <class T>
constexpr std::size_t doubles() {
  return std::is_same_v<T, Vec3> ? 3 : 1;
}

}  // namespace

void ParticleStore::resize(std::size_t n) {
  for_each_column([&](auto& col, int width, bool, bool) {
    using T = typename std::decay_t<decltype(col)>::value_type;
    col.resize(n * width, zero<T>());
  });
}

void ParticleStore::resize_ghosts(std::size_t n) {
  for_each_column([&](auto& col, int width, bool, bool ghosts) {
    using T = typename std::decay_t<decltype(col)>::value_type;
    col.resize((ghosts ? nlocal + n : nlocal) * width, zero<T>());
  });
}

void ParticleStore::add(std::int64_t pid, int sp, double a, double m, const Vec3& pos, const Vec3& vel) {
  const std::size_t i = size();
  resize(i + 1);  // every column of the new particle zero
  id[i] = pid;
  species[i] = sp;
  radius[i] = a;
  mass[i] = m;
  inv_mass[i] = 1.0 / m;
  x[i] = pos;
  v[i] = vel;
  x_build[i] = pos;
  if (rotation) inv_inertia[i] = 1.0 / (0.4 * m * a * a);  // solid sphere: I = 2/5 m a^2
}

void ParticleStore::copy(std::size_t from, std::size_t to) {
  for_each_column([&](auto& col, int width, bool, bool) {
    for (int w = 0; w < width; ++w) col[to * width + w] = col[from * width + w];
  });
}

void ParticleStore::permute_local(const std::vector<std::size_t>& order) {
  // In place, cycle by cycle (new slot k takes old slot order[k]): no second copy of any column.
  // Each column keeps its buffer and the room it had for ghosts, so nothing is reallocated and
  // the peak memory of a rebuild is not raised by a reordering.
  const std::size_t n = order.size();
  std::vector<bool> seen(n, false);
  std::vector<std::size_t> leaders;  // one slot of every cycle longer than one
  for (std::size_t k = 0; k < n; ++k) {
    if (seen[k] || order[k] == k) continue;
    leaders.push_back(k);
    for (std::size_t j = k; !seen[j]; j = order[j]) seen[j] = true;
  }
  for_each_column([&](auto& vec, int width, bool, bool) {
    using T = typename std::decay_t<decltype(vec)>::value_type;
    vec.resize(n * width);  // ghosts dropped
    std::vector<T> held(width);
    for (const std::size_t k : leaders) {
      std::copy_n(vec.begin() + k * width, width, held.begin());
      std::size_t j = k;
      for (std::size_t from = order[j]; from != k; j = from, from = order[j])
        std::copy_n(vec.begin() + from * width, width, vec.begin() + j * width);
      std::copy_n(held.begin(), width, vec.begin() + j * width);
    }
  });
  nlocal = n;
}

std::size_t ParticleStore::declare(const std::string& name, int width, Ghosts ghosts, const std::string& unit,
                                   const FormerColumn& former) {
  for (const auto& c : module_columns)
    if (c.name == name) throw std::logic_error("particle column '" + name + "' declared twice");
  if (size() != 0) throw std::logic_error("particle column '" + name + "' declared after particles exist");
  module_columns.push_back({name, width, ghosts, unit, former, {}});
  return module_columns.size() - 1;
}

int ParticleStore::ghost_column_width() const {
  int w = 0;
  for (const auto& c : module_columns)
    if (c.carried()) w += c.width;
  return w;
}

std::size_t ParticleStore::packed_size() const {
  std::size_t n = 0;
  for_each_column([&](const auto& col, int width, bool migrates, bool) {
    using T = typename std::decay_t<decltype(col)>::value_type;
    if (migrates) n += width * doubles<T>();
  });
  return n;
}

void ParticleStore::pack(std::size_t i, std::vector<double>& buf) const {
  for_each_column([&](const auto& col, int width, bool migrates, bool) {
    if (!migrates) return;
    for (int w = 0; w < width; ++w) put(buf, col[i * width + w]);
  });
}

std::size_t ParticleStore::unpack(const std::vector<double>& buf, std::size_t o) {
  const std::size_t i = size();
  resize(i + 1);
  for_each_column([&](auto& col, int width, bool migrates, bool) {
    if (!migrates) return;
    for (int w = 0; w < width; ++w) o = get(buf, o, col[i * width + w]);
  });
  inv_mass[i] = 1.0 / mass[i];
  if (rotation) inv_inertia[i] = 1.0 / (0.4 * mass[i] * radius[i] * radius[i]);
  return o;
}

}  // namespace cassini
