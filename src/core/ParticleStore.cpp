#include "core/ParticleStore.hpp"

#include <cstring>

namespace cassini {

void ParticleStore::resize(std::size_t n) {
  id.resize(n);
  species.resize(n);
  radius.resize(n);
  mass.resize(n);
  inv_mass.resize(n);
  x.resize(n);
  v.resize(n);
  f.resize(n, Vec3::Zero());
  x_build.resize(n);
  mode.resize(n, 0);
  if (rotation) {
    omega.resize(n, Vec3::Zero());
    torque.resize(n, Vec3::Zero());
    inv_inertia.resize(n);
    wall_xi.resize(n * walls, Vec3::Zero());
  }
  if (impacts) wall_impact.resize(n * walls, 0.0);
  if (rolling) wall_roll.resize(n * walls, Vec3::Zero());
}

void ParticleStore::add(std::int64_t pid, int sp, double a, double m, const Vec3& pos, const Vec3& vel) {
  const std::size_t i = size();
  resize(i + 1);
  id[i] = pid;
  species[i] = sp;
  radius[i] = a;
  mass[i] = m;
  inv_mass[i] = 1.0 / m;
  x[i] = pos;
  v[i] = vel;
  x_build[i] = pos;
  mode[i] = 0;
  if (rotation) {
    omega[i].setZero();
    inv_inertia[i] = 1.0 / (0.4 * m * a * a);  // solid sphere: I = 2/5 m a^2
    for (int w = 0; w < walls; ++w) wall_xi[i * walls + w].setZero();
  }
  if (impacts)
    for (int w = 0; w < walls; ++w) wall_impact[i * walls + w] = 0;
  if (rolling)
    for (int w = 0; w < walls; ++w) wall_roll[i * walls + w].setZero();
}

void ParticleStore::copy(std::size_t from, std::size_t to) {
  id[to] = id[from];
  species[to] = species[from];
  radius[to] = radius[from];
  mass[to] = mass[from];
  inv_mass[to] = inv_mass[from];
  x[to] = x[from];
  v[to] = v[from];
  f[to] = f[from];
  x_build[to] = x_build[from];
  mode[to] = mode[from];
  if (rotation) {
    omega[to] = omega[from];
    torque[to] = torque[from];
    inv_inertia[to] = inv_inertia[from];
    for (int w = 0; w < walls; ++w) wall_xi[to * walls + w] = wall_xi[from * walls + w];
  }
  if (impacts)
    for (int w = 0; w < walls; ++w) wall_impact[to * walls + w] = wall_impact[from * walls + w];
  if (rolling)
    for (int w = 0; w < walls; ++w) wall_roll[to * walls + w] = wall_roll[from * walls + w];
}

void ParticleStore::permute_local(const std::vector<std::size_t>& order) {
  // Into a scratch array kept per element type, then swapped: no allocation after the first
  // rebuilds. A fresh array per column (as before) cost a page fault per 4 KiB at every rebuild,
  // and the ghosts appended next had to reallocate every column again.
  auto apply = [&](auto& vec, std::size_t width) {
    using T = typename std::decay_t<decltype(vec)>::value_type;
    static thread_local std::vector<T> out;
    out.resize(order.size() * width);
    for (std::size_t k = 0; k < order.size(); ++k)
      for (std::size_t w = 0; w < width; ++w) out[k * width + w] = vec[order[k] * width + w];
    vec.swap(out);
    if (vec.capacity() < out.capacity()) vec.reserve(out.capacity());  // room for the ghosts
  };
  apply(id, 1);
  apply(species, 1);
  apply(radius, 1);
  apply(mass, 1);
  apply(inv_mass, 1);
  apply(x, 1);
  apply(v, 1);
  apply(f, 1);
  apply(x_build, 1);
  apply(mode, 1);
  if (rotation) {
    apply(omega, 1);
    apply(torque, 1);
    apply(inv_inertia, 1);
    apply(wall_xi, walls);
  }
  if (impacts) apply(wall_impact, walls);
  if (rolling) apply(wall_roll, walls);
  nlocal = order.size();
}

std::size_t ParticleStore::packed_size() const {
  // id, species, radius, mass, x, v, x_build, f, mode (+ omega, torque, wall_xi) (+ wall_impact) (+ wall_roll)
  return 5 + 12 + (rotation ? 6 + 3 * walls : 0) + (impacts ? walls : 0) + (rolling ? 3 * walls : 0);
}

void ParticleStore::pack(std::size_t i, std::vector<double>& buf) const {
  double idd;
  static_assert(sizeof(idd) == sizeof(id[i]));
  std::memcpy(&idd, &id[i], sizeof idd);  // ids travel bit-exactly inside the double buffer
  buf.push_back(idd);
  buf.push_back(species[i]);
  buf.push_back(radius[i]);
  buf.push_back(mass[i]);
  // f travels too: after a rebuild at the end of a step the next kick needs F(t).
  for (const Vec3* q : {&x[i], &v[i], &x_build[i], &f[i]}) buf.insert(buf.end(), q->data(), q->data() + 3);
  buf.push_back(mode[i]);
  if (rotation) {
    buf.insert(buf.end(), omega[i].data(), omega[i].data() + 3);
    buf.insert(buf.end(), torque[i].data(), torque[i].data() + 3);
    for (int w = 0; w < walls; ++w) buf.insert(buf.end(), wall_xi[i * walls + w].data(), wall_xi[i * walls + w].data() + 3);
  }
  if (impacts)
    for (int w = 0; w < walls; ++w) buf.push_back(wall_impact[i * walls + w]);
  if (rolling)
    for (int w = 0; w < walls; ++w) buf.insert(buf.end(), wall_roll[i * walls + w].data(), wall_roll[i * walls + w].data() + 3);
}

std::size_t ParticleStore::unpack(const std::vector<double>& buf, std::size_t o) {
  std::int64_t pid;
  std::memcpy(&pid, &buf[o], sizeof pid);
  const Vec3 pos(buf[o + 4], buf[o + 5], buf[o + 6]);
  const Vec3 vel(buf[o + 7], buf[o + 8], buf[o + 9]);
  add(pid, static_cast<int>(buf[o + 1]), buf[o + 2], buf[o + 3], pos, vel);
  const std::size_t i = size() - 1;
  x_build[i] = Vec3(buf[o + 10], buf[o + 11], buf[o + 12]);
  f[i] = Vec3(buf[o + 13], buf[o + 14], buf[o + 15]);
  mode[i] = static_cast<std::uint8_t>(buf[o + 16]);
  o += 17;
  if (rotation) {
    omega[i] = Vec3(buf[o], buf[o + 1], buf[o + 2]);
    torque[i] = Vec3(buf[o + 3], buf[o + 4], buf[o + 5]);
    o += 6;
    for (int w = 0; w < walls; ++w, o += 3) wall_xi[i * walls + w] = Vec3(buf[o], buf[o + 1], buf[o + 2]);
  }
  if (impacts)
    for (int w = 0; w < walls; ++w) wall_impact[i * walls + w] = buf[o++];
  if (rolling)
    for (int w = 0; w < walls; ++w, o += 3) wall_roll[i * walls + w] = Vec3(buf[o], buf[o + 1], buf[o + 2]);
  return o;
}

}  // namespace cassini
