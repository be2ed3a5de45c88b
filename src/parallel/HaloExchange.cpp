#include "parallel/HaloExchange.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace cassini {
namespace {

double id_bits(std::int64_t id) {
  double d;
  std::memcpy(&d, &id, sizeof d);
  return d;
}
std::int64_t bits_id(double d) {
  std::int64_t id;
  std::memcpy(&id, &d, sizeof id);
  return id;
}

}  // namespace

std::vector<std::vector<double>>& HaloExchange::empty_buffers() {
  // One set of send buffers for migration, ghost builds and ghost updates, emptied but never
  // freed: their sizes change little from one rebuild to the next.
  out_.resize(dom_.nranks);
  for (auto& b : out_) b.clear();
  return out_;
}

double HaloExchange::shift_x(const Image& im) const {
  double s = im.k[0] * dom_.length[0];
  // Offset relative to its wrap at the last build, so an image does not jump by Lx when the
  // offset wraps between rebuilds.
  if (dom_.shear.enabled) s += im.k[1] * (dom_.shear.offset - shear_base_);
  return s;
}

Vec3 HaloExchange::shift(const Image& im) const {
  return Vec3(shift_x(im), im.k[1] * dom_.length[1], im.k[2] * dom_.length[2]);
}

void HaloExchange::image_state(const ParticleStore& p, const Image& im, double* x, double* v) const {
  // Component by component: a shift built as a Vec3 goes through the stack, and the vector load
  // of components just stored one by one stalls (store forwarding fails): that was half of the
  // per-step ghost update's time.
  const std::size_t i = im.index;
  x[0] = p.x[i][0] + shift_x(im);
  x[1] = p.x[i][1] + im.k[1] * dom_.length[1];
  x[2] = p.x[i][2] + im.k[2] * dom_.length[2];
  v[0] = p.v[i][0] + shear_velocity(im);
  v[1] = p.v[i][1];
  v[2] = p.v[i][2];
}

double HaloExchange::shear_velocity(const Image& im) const {
  return dom_.shear.enabled ? im.k[1] * dom_.shear.rate * dom_.length[1] : 0.0;
}

void HaloExchange::exchange(std::vector<std::vector<double>>& out, std::vector<double>& in,
                            const std::vector<int>* known) {
  // Point to point from each destination's own buffer: no concatenated copy of everything sent
  // (that copy was allocated at every ghost update), and this rank's part is one copy, without
  // MPI (migration; the ghost exchanges write a rank's own images straight to their slots).
  const int n = dom_.nranks, me = dom_.rank;
  std::vector<int> scount(n), rcount(n);
  for (int r = 0; r < n; ++r) {
    scount[r] = static_cast<int>(out[r].size());
    if (r != me && scount[r] > 0) {
      bytes_sent += static_cast<std::int64_t>(scount[r]) * static_cast<std::int64_t>(sizeof(double));
      ++messages_sent;
    }
  }
  if (known) rcount = *known;
  else MPI_Alltoall(scount.data(), 1, MPI_INT, rcount.data(), 1, MPI_INT, dom_.comm);
  std::vector<std::size_t> rdispl(n + 1, 0);
  for (int r = 0; r < n; ++r) rdispl[r + 1] = rdispl[r] + rcount[r];
  if (rcount[me] != scount[me]) throw std::logic_error("HaloExchange: this rank's own images miscounted");
  in.resize(rdispl[n]);
  constexpr int kTag = 7301;
  std::vector<MPI_Request> requests;
  requests.reserve(2 * n);
  for (int r = 0; r < n; ++r)
    if (r != me && rcount[r] > 0) {
      requests.emplace_back();
      MPI_Irecv(in.data() + rdispl[r], rcount[r], MPI_DOUBLE, r, kTag, dom_.comm, &requests.back());
    }
  for (int r = 0; r < n; ++r)
    if (r != me && scount[r] > 0) {
      requests.emplace_back();
      MPI_Isend(out[r].data(), scount[r], MPI_DOUBLE, r, kTag, dom_.comm, &requests.back());
    }
  std::copy(out[me].begin(), out[me].end(), in.begin() + rdispl[me]);
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
}

namespace {
// Crossed an x face (before the sheared boundary's shift: a particle that left through a
// corner crossed both; a sheared crossing alone keeps a particle in its copy).
bool crossed_x(const Decomposition& dom, const Vec3& x) { return x[0] < dom.lo[0] || x[0] >= dom.hi[0]; }
// A particle that crossed x did so with the shear flow gamma_dot y (out through hi where the flow
// is positive, through lo where it is negative) or against it.
bool crossed_against_flow(const Decomposition& dom, const Vec3& x) {
  return (x[0] >= dom.hi[0]) != (dom.shear.rate * x[1] > 0);
}
}  // namespace

void HaloExchange::feed(ParticleStore& p) {
  if (next_id < 0) {  // a fresh run: ids after every initial one
    std::int64_t mine = -1;
    for (std::size_t i = 0; i < p.nlocal; ++i) mine = std::max(mine, p.id[i]);
    MPI_Allreduce(&mine, &next_id, 1, MPI_INT64_T, MPI_MAX, dom_.comm);
    ++next_id;
  }
  std::vector<std::int64_t> sources;
  std::vector<std::size_t> slots;
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (p.le_copy[i] == 1 && crossed_x(dom_, p.x[i]) && !crossed_against_flow(dom_, p.x[i])) {
      sources.push_back(p.id[i]);
      slots.push_back(i);
    }
  // Every rank learns every crossing id, so the clones' ids do not depend on the rank count.
  int n = static_cast<int>(sources.size());
  std::vector<int> counts(dom_.nranks), displ(dom_.nranks, 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, dom_.comm);
  for (int r = 1; r < dom_.nranks; ++r) displ[r] = displ[r - 1] + counts[r - 1];
  std::vector<std::int64_t> all(displ.back() + counts.back());
  MPI_Allgatherv(sources.data(), n, MPI_INT64_T, all.data(), counts.data(), displ.data(), MPI_INT64_T, dom_.comm);
  std::sort(all.begin(), all.end());
  const double Lx = dom_.length[0];
  const std::size_t entered = p.find_column(kEnteredColumn), shown = p.find_column(kInflowColumn);
  for (std::size_t k = 0; k < slots.size(); ++k) {
    const std::size_t j = p.size();
    p.resize(j + 1);
    p.copy(slots[k], j);  // its whole state: the clone is where its original re-enters LE2
    p.le_copy[j] = 0;
    *p.column(entered, j) = 1;
    *p.column(shown, j) = 0;
    p.id[j] = next_id + (std::lower_bound(all.begin(), all.end(), sources[k]) - all.begin());
    p.x[j][0] -= Lx * std::floor((p.x[j][0] - dom_.lo[0]) / Lx);
    if (p.x[j][0] >= dom_.hi[0]) p.x[j][0] = dom_.lo[0];
    shear_energy += 0.5 * p.mass[j] * p.v[j].squaredNorm();  // the boundary's work (energy guard)
  }
  p.nlocal = p.size();
  next_id += static_cast<std::int64_t>(all.size());
  fed += static_cast<std::int64_t>(slots.size());
}

void HaloExchange::migrate(ParticleStore& p, PairHistory& history) {
  p.resize(p.nlocal);  // drop ghosts
  if (dom_.fed_x) feed(p);
  // The history is looked up by owner for the particles that leave: sorted when the first one
  // does (most rebuilds of a periodic box on one rank move nobody away).
  bool sorted = false;
  auto sort_history = [&] {
    if (!sorted) history.sort();
    sorted = true;
  };
  std::vector<std::vector<double>>& out = empty_buffers();
  const Vec3 L = dom_.length;
  const std::size_t entered = dom_.fed_x ? p.find_column(kEnteredColumn) : ParticleStore::kNoColumn;
  for (std::size_t i = p.nlocal; i-- > 0;) {
    Vec3& x = p.x[i];
    const bool left_le1 = dom_.fed_x && p.le_copy[i] == 0 && crossed_x(dom_, x);
    const bool drain = left_le1 && !crossed_against_flow(dom_, x);  // out with the flow: removed
    if (left_le1 && !drain) {  // out against it: back in through the opposite face (the wrap below)
      ++returned;
      *p.column(entered, i) = 2;
    }
    bool gone = drain;
    if (drain) {
      ++drained;
      shear_energy -= 0.5 * p.mass[i] * p.v[i].squaredNorm();
    }
    double jump = 0;
    if (dom_.shear.enabled && !drain) {  // crossing the sheared boundary: shift x, jump vx (not for one leaving)
      const double off = dom_.shear.wrapped(L[0]), dv = dom_.shear.rate * L[1];
      if (x[1] >= dom_.hi[1]) { x[1] -= L[1]; x[0] -= off; jump = -dv; }
      else if (x[1] < dom_.lo[1]) { x[1] += L[1]; x[0] += off; jump = dv; }
      if (jump != 0) {
        shear_energy += p.mass[i] * (p.v[i][0] * jump + 0.5 * jump * jump);
        p.v[i][0] += jump;
        shear_momentum += p.mass[i] * jump;
        ++shear_crossings;
      }
    }
    for (int d = 0; d < dom_.dims; ++d) {
      if (dom_.periodic(d)) {
        if (x[d] >= dom_.lo[d] && x[d] < dom_.hi[d]) continue;  // inside: the wrap below is x - 0
        x[d] -= L[d] * std::floor((x[d] - dom_.lo[d]) / L[d]);
        if (x[d] >= dom_.hi[d]) x[d] = dom_.lo[d];  // round-off at the upper face
      } else if (dom_.boundary[d] == Boundary::Open && (x[d] < dom_.lo[d] || x[d] >= dom_.hi[d])) {
        if (!gone && x[d] >= dom_.hi[d]) ++removed_upper;
        gone = true;
      }
    }
    // An LE1 particle that wrapped through y may land next to what it could not see from
    // across y (unseen_after_wrap); Simulation::remove_stillborn takes it out if it landed on it.
    if (jump != 0 && dom_.fed_x && p.le_copy[i] == 0 && *p.column(entered, i) == 0) *p.column(entered, i) = 3;
    const int dest = dom_.owner(x);
    if (gone || dest != dom_.rank) {
      if (!gone) {
        auto& buf = out[dest];
        p.pack(i, buf);
        sort_history();
        const auto [b, e] = history.rows_of(p.id[i]);
        buf.push_back(static_cast<double>(e - b));
        for (std::size_t h = b; h < e; ++h) {
          buf.push_back(id_bits(history.partner[h]));
          buf.insert(buf.end(), history.row(h), history.row(h) + history.width());
        }
      } else if (!drain) {
        ++removed;
      }
      const std::size_t last = p.nlocal - 1;
      if (i != last) p.copy(last, i);
      p.nlocal = last;
      p.resize(last);
    }
  }
  std::vector<double>& in = in_;
  exchange(out, in);
  for (std::size_t o = 0; o < in.size();) {
    o = p.unpack(in, o);
    const std::int64_t owner = p.id[p.size() - 1];
    const auto nh = static_cast<std::size_t>(in[o++]);
    const std::size_t w = static_cast<std::size_t>(history.width());
    for (std::size_t h = 0; h < nh; ++h, o += 1 + w)
      std::copy_n(&in[o + 1], w, history.add(owner, bits_id(in[o])));
    p.nlocal = p.size();
  }
  for (std::size_t i = 0; i < p.nlocal; ++i)
    if (dom_.owner(p.x[i]) != dom_.rank)
      throw std::runtime_error("particle " + std::to_string(p.id[i]) +
                               " landed outside its rank's region after migration (moved more than the box in one rebuild interval)");
}

void HaloExchange::build_ghosts(ParticleStore& p) {
  p.resize(p.nlocal);
  send_.resize(dom_.nranks);
  for (auto& s : send_) s.clear();  // kept: the lists of the last build had the right size
  const Vec3 L = dom_.length;
  const bool sheared = dom_.shear.enabled;
  const double off = sheared ? dom_.shear.wrapped(L[0]) : 0.0;
  shear_base_ = dom_.shear.offset - off;
  const std::size_t shown = dom_.fed_x ? p.find_column(kInflowColumn) : ParticleStore::kNoColumn;

  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const Vec3& x = p.x[i];
    // Most particles: only their own image, on this rank alone (the loop below would find just
    // that, at ~200 instructions a particle).
    if (dom_.deep_inside(x, range_)) continue;
    // Candidate image shifts per axis: 0, plus one box length when near a periodic face.
    std::int8_t cand[3][6];
    int nc[3];
    for (int d = 0; d < 3; ++d) {
      nc[d] = 0;
      cand[d][nc[d]++] = 0;
      if (d >= dom_.dims) continue;
      if (dom_.periodic(d) || (sheared && d == 1)) {
        if (x[d] < dom_.lo[d] + range_) cand[d][nc[d]++] = 1;
        if (x[d] >= dom_.hi[d] - range_) cand[d][nc[d]++] = -1;
      }
    }
    const std::uint8_t copy = p.copies ? p.le_copy[i] : 0;
    // Modified Lees-Edwards boundaries: upstream of LE1's inflow faces lies LE2. An LE2
    // particle within range of the face its flow leaves through is also an LE1 ghost beyond
    // the opposite (inflow) face, at x + inflow L. Beyond an outflow face LE2 would show LE1's
    // own material a second time (LE1 is LE2 plus the moonlet's disturbance): LE1 sees nothing
    // there, and LE1 particles have no x images. Across y each copy is an ordinary sheared box.
    int inflow = 0;
    if (dom_.fed_x && copy == 1) {
      const double flow = dom_.shear.rate * x[1];  // the imposed flow v_x
      if (flow > 0 && x[0] >= dom_.hi[0] - range_) inflow = -1;
      else if (flow < 0 && x[0] < dom_.lo[0] + range_) inflow = 1;
      // Shown only once it came into range from inside LE2 (then the image first appears about
      // `range` beyond the face, clear of LE1), and for as long as it stays: not when it got
      // there by a wrap (an x crossing against the flow, or a sheared crossing) or by y changing
      // sign near the face. Such an image would appear on top of LE1 material, on its own twin
      // when LE1 is still LE2 there (near y = 0, far from the moonlet, for orbits).
      double& on = *p.column(shown, i);
      const Vec3& xb = p.x_build[i];  // the position at the last build
      const bool wrapped = std::abs(x[0] - xb[0]) > 0.5 * L[0] || std::abs(x[1] - xb[1]) > 0.5 * L[1];
      const bool from_inside = inflow == -1 ? xb[0] < dom_.hi[0] - range_ : xb[0] >= dom_.lo[0] + range_;
      if (wrapped || !(on != 0 || from_inside)) inflow = 0;
      on = inflow != 0 ? 1.0 : 0.0;
    }
    for (int iy = 0; iy < nc[1]; ++iy) {
      const std::int8_t ky = cand[1][iy];
      // (x image, copy) pairs. A sheared image's x moves by the offset, so it may need any x
      // wrap to land near the box.
      std::int8_t kxs[12];
      std::uint8_t copies[12];
      int nkx = 0;
      auto sheared_wraps = [&](int base, std::uint8_t c) {
        for (int kx = -2; kx <= 2; ++kx) {
          const double xi = x[0] + ky * off + (base + kx) * L[0];
          if (xi >= dom_.lo[0] - range_ && xi < dom_.hi[0] + range_) {
            kxs[nkx] = static_cast<std::int8_t>(base + kx);
            copies[nkx++] = c;
          }
        }
      };
      if (sheared && ky != 0) {
        sheared_wraps(0, copy);
      } else {
        for (int ix = 0; ix < nc[0]; ++ix) {
          const std::int8_t kx = cand[0][ix];
          if (dom_.fed_x && kx != 0 && copy == 0) continue;
          kxs[nkx] = kx;
          copies[nkx++] = copy;
          if (dom_.fed_x && kx != 0 && kx == inflow) {
            kxs[nkx] = kx;
            copies[nkx++] = 0;
          }
        }
      }
      for (int ix = 0; ix < nkx; ++ix)
        for (int iz = 0; iz < nc[2]; ++iz) {
          const Image im{static_cast<std::uint32_t>(i), {kxs[ix], ky, cand[2][iz]}, copies[ix]};
          dom_.ranks_near(x + shift(im), range_, near_);
          for (const int r : near_)
            if (r != dom_.rank || im.k[0] != 0 || im.k[1] != 0 || im.k[2] != 0) send_[r].push_back(im);
        }
    }
  }

  // First exchange carries the full description of each ghost; later ones only the motion.
  const int extra = p.ghost_column_width();  // the modules' columns, last
  const std::size_t width = 11 + (p.rotation ? 3 : 0) + (p.copies ? 1 : 0) + extra;
  auto describe = [&](const Image& im, double* b) {
    const std::size_t i = im.index;
    const Vec3 xs = p.x[i] + shift(im);
    const double head[11] = {id_bits(p.id[i]), double(p.species[i]), p.radius[i], p.mass[i], xs[0], xs[1], xs[2],
                             p.v[i][0] + shear_velocity(im), p.v[i][1], p.v[i][2], double(im.k[1])};
    b = std::copy_n(head, 11, b);
    if (p.rotation) b = std::copy_n(p.omega[i].data(), 3, b);
    if (p.copies) *b++ = im.copy;
    for (const auto& c : p.module_columns)
      if (c.carried()) b = std::copy_n(&c.data[i * c.width], c.width, b);
  };
  auto unpack = [&](const double* b, std::size_t j) {
    p.id[j] = bits_id(b[0]);
    p.species[j] = static_cast<std::int32_t>(b[1]);
    p.radius[j] = b[2];
    p.mass[j] = b[3];
    p.inv_mass[j] = 1.0 / b[3];
    p.x[j] = Vec3(b[4], b[5], b[6]);
    p.v[j] = Vec3(b[7], b[8], b[9]);
    ghost_sheared_[j - p.nlocal] = static_cast<std::int8_t>(b[10]);
    if (p.rotation) p.omega[j] = Vec3(b[11], b[12], b[13]);
    if (p.copies) p.le_copy[j] = static_cast<std::uint8_t>(b[width - extra - 1]);
    const double* q = b + width - extra;
    for (auto& c : p.module_columns)
      if (c.carried()) {
        std::copy_n(q, c.width, &c.data[j * c.width]);
        q += c.width;
      }
  };
  // This rank's own images (every ghost, on one rank) are written straight from their
  // originals below, never buffered.
  const int me = dom_.rank;
  std::vector<std::vector<double>>& out = empty_buffers();
  for (int r = 0; r < dom_.nranks; ++r) {
    if (r == me) continue;
    out[r].resize(send_[r].size() * width);
    for (std::size_t s = 0; s < send_[r].size(); ++s) describe(send_[r][s], &out[r][s * width]);
  }
  std::vector<double>& in = in_;
  exchange(out, in);
  // Remember the receive sizes of the per-step update; one more Alltoall gives them.
  std::vector<int> scount(dom_.nranks);
  for (int r = 0; r < dom_.nranks; ++r) scount[r] = static_cast<int>(send_[r].size());
  recv_ghosts_.assign(dom_.nranks, 0);
  MPI_Alltoall(scount.data(), 1, MPI_INT, recv_ghosts_.data(), 1, MPI_INT, dom_.comm);
  recv_doubles_.resize(dom_.nranks);
  for (int r = 0; r < dom_.nranks; ++r) recv_doubles_[r] = recv_ghosts_[r] * int(6 + (p.rotation ? 3 : 0) + extra);
  p.resize_ghosts(in.size() / width + send_[me].size());
  ghost_sheared_.resize(p.nghost());
  first_ghost_.assign(dom_.nranks + 1, p.nlocal);
  for (int r = 0; r < dom_.nranks; ++r)
    first_ghost_[r + 1] = first_ghost_[r] + (r == me ? send_[me].size() : std::size_t(recv_ghosts_[r]));
  images_start_.assign(p.nlocal + 1, 0);
  sheared_.resize(dom_.nranks);
  for (int r = 0; r < dom_.nranks; ++r) {
    sheared_[r].clear();
    for (std::size_t s = 0; s < send_[r].size(); ++s) {
      ++images_start_[send_[r][s].index + 1];
      if (send_[r][s].k[1] != 0) sheared_[r].push_back(static_cast<std::uint32_t>(s));
    }
  }
  for (std::size_t i = 0; i < p.nlocal; ++i) images_start_[i + 1] += images_start_[i];
  images_.resize(images_start_[p.nlocal]);
  {
    std::vector<std::uint32_t> at(images_start_.begin(), images_start_.end() - 1);
    for (int r = 0; r < dom_.nranks; ++r)
      for (std::size_t s = 0; s < send_[r].size(); ++s) images_[at[send_[r][s].index]++] = {r, static_cast<std::uint32_t>(s)};
  }
  // Ghosts by source rank, in send order (update_ghosts relies on it).
  scratch_.resize(width);
  const double* b = in.data();
  std::size_t j = p.nlocal;
  for (int r = 0; r < dom_.nranks; ++r) {
    if (r == me) {
      for (const Image& im : send_[me]) {
        describe(im, scratch_.data());
        unpack(scratch_.data(), j++);
      }
      continue;
    }
    for (int g = 0; g < recv_ghosts_[r]; ++g, b += width) unpack(b, j++);
  }
}

std::size_t HaloExchange::ghost_width(const ParticleStore& p) const {
  return 6 + (p.rotation ? 3 : 0) + p.ghost_column_width();
}

void HaloExchange::pack_ghost(const ParticleStore& p, const Image& im, double* q) const {
  const std::size_t i = im.index;
  image_state(p, im, q, q + 3);
  if (p.rotation) { q[6] = p.omega[i][0]; q[7] = p.omega[i][1]; q[8] = p.omega[i][2]; }
  double* e = q + 6 + (p.rotation ? 3 : 0);
  for (const auto& c : p.module_columns)
    if (c.carried()) e = std::copy_n(&c.data[i * c.width], c.width, e);
}

void HaloExchange::unpack_ghost(ParticleStore& p, const double* b, std::size_t j) const {
  p.x[j] = Vec3(b[0], b[1], b[2]);
  p.v[j] = Vec3(b[3], b[4], b[5]);
  if (p.rotation) p.omega[j] = Vec3(b[6], b[7], b[8]);
  const double* e = b + 6 + (p.rotation ? 3 : 0);
  for (auto& c : p.module_columns)
    if (c.carried()) {
      std::copy_n(e, c.width, &c.data[j * c.width]);
      e += c.width;
    }
}

void HaloExchange::write_own_image(ParticleStore& p, const Image& im, std::size_t j) const {
  const std::size_t i = im.index;
  image_state(p, im, p.x[j].data(), p.v[j].data());
  if (p.rotation) p.omega[j] = p.omega[i];
  for (auto& c : p.module_columns)
    if (c.carried()) std::copy_n(&c.data[i * c.width], c.width, &c.data[j * c.width]);
}

void HaloExchange::update_ghosts(ParticleStore& p) {
  const std::size_t width = ghost_width(p);
  const int me = dom_.rank;
  for (int r = 0; r < dom_.nranks; ++r) {
    auto& b = out_[r];
    b.resize(r == me ? 0 : send_[r].size() * width);  // this rank's own images: below, unbuffered
    double* q = b.data();
    for (std::size_t s = 0; r != me && s < send_[r].size(); ++s, q += width) pack_ghost(p, send_[r][s], q);
  }
  recv_others_ = recv_doubles_;
  recv_others_[me] = 0;
  exchange(out_, in_, &recv_others_);
  // Ghosts are stored by source rank, in send order. On one rank every ghost is a periodic
  // image of an own particle: written straight from it, where packing, copying and unpacking
  // it went over the ghosts' data three times.
  const double* b = in_.data();
  std::size_t j = p.nlocal;
  for (int r = 0; r < dom_.nranks; ++r) {
    if (r == me) {  // the same values as pack_ghost() gives, copied slot to slot (no staging)
      for (const Image& im : send_[me]) write_own_image(p, im, j++);
      continue;
    }
    for (int g = 0; g < recv_ghosts_[r]; ++g, b += width) unpack_ghost(p, b, j++);
  }
}

void HaloExchange::update_ghosts_of(ParticleStore& p, const std::vector<std::uint32_t>& changed, bool sheared) {
  if (sheared && full_updates) {
    update_ghosts(p);
    return;
  }
  const std::size_t width = ghost_width(p), row = 1 + width;  // a row: the ghost's place in send order, its values
  const int n = dom_.nranks, me = dom_.rank;
  // To every rank this one sends ghosts to: a count, then the rows of the changed ones.
  constexpr int kTag = 7302;
  std::vector<MPI_Request> requests;
  requests.reserve(2 * n);
  std::vector<std::size_t> at(n + 1, 0);  // receive buffer offsets (room for every ghost)
  for (int r = 0; r < n; ++r) at[r + 1] = at[r] + (r != me && recv_ghosts_[r] > 0 ? 1 + recv_ghosts_[r] * row : 0);
  in_.resize(at[n]);
  for (int r = 0; r < n; ++r)
    if (r != me && recv_ghosts_[r] > 0) {
      requests.emplace_back();
      MPI_Irecv(in_.data() + at[r], int(at[r + 1] - at[r]), MPI_DOUBLE, r, kTag, dom_.comm, &requests.back());
    }
  auto add_row = [&](int r, std::uint32_t s) {
    auto& b = out_[r];
    b.resize(b.size() + row);
    double* q = &b[b.size() - row];
    q[0] = double(s);
    pack_ghost(p, send_[r][s], q + 1);
  };
  for (int r = 0; r < n; ++r) {
    if (r == me || send_[r].empty()) continue;
    out_[r].assign(1, 0.0);
    if (sheared)
      for (const std::uint32_t s : sheared_[r]) add_row(r, s);
  }
  // This rank's own images first: a sheared one's position follows the offset (only x moves).
  if (sheared)
    for (const std::uint32_t s : sheared_[me]) {
      const Image& im = send_[me][s];
      p.x[first_ghost_[me] + s][0] = p.x[im.index][0] + shift_x(im);
    }
  // Then every image of a changed particle (a sheared one to another rank is already in its
  // rows), once: a row more than the ghosts a rank holds would not fit its receive.
  // Most changed particles have no image (they are not near a face): skipped on one load.
  if (changed_.size() < p.nlocal) changed_.resize(p.nlocal, 0);
  const std::uint32_t* first = images_start_.data();
  std::size_t marked = 0;
  for (const std::uint32_t i : changed) {
    const std::uint32_t k0 = first[i], k1 = first[i + 1];
    if (k0 == k1 || changed_[i]) continue;
    changed_[i] = 1;
    ++marked;
    for (std::uint32_t k = k0; k < k1; ++k) {
      const ImageRef ref = images_[k];
      if (ref.rank == me) write_own_image(p, send_[me][ref.slot], first_ghost_[me] + ref.slot);
      else if (!(sheared && send_[ref.rank][ref.slot].k[1] != 0)) add_row(ref.rank, ref.slot);
    }
  }
  if (marked > 0)
    for (const std::uint32_t i : changed) changed_[i] = 0;
  for (int r = 0; r < n; ++r) {
    if (r == me || send_[r].empty()) continue;
    auto& b = out_[r];
    b[0] = double((b.size() - 1) / row);
    bytes_sent += static_cast<std::int64_t>(b.size() * sizeof(double));
    ++messages_sent;
    requests.emplace_back();
    MPI_Isend(b.data(), int(b.size()), MPI_DOUBLE, r, kTag, dom_.comm, &requests.back());
  }
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
  for (int r = 0; r < n; ++r) {
    if (r == me || recv_ghosts_[r] == 0) continue;
    const double* b = in_.data() + at[r];
    const std::size_t rows = std::size_t(b[0]);
    for (std::size_t k = 0; k < rows; ++k) {
      const double* q = b + 1 + k * row;
      unpack_ghost(p, q + 1, first_ghost_[r] + std::size_t(q[0]));
    }
  }
}

}  // namespace cassini
