#include "physics/contact/ContactForces.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "core/CaseFile.hpp"
#include "core/Simulation.hpp"

namespace cassini {

namespace {
// assign(n, value) with room to spare when it must grow: the lists' length wanders up and down
// between rebuilds, and an exact fit would be reallocated (fresh pages) whenever it reaches a
// new maximum.
template <class Vector, class T>
void refill(Vector& v, std::size_t n, const T& value) {
  if (n > v.capacity()) v.reserve(n + n / 8);
  v.assign(n, value);
}
}  // namespace

void ContactForces::force(Simulation& sim) {
  // The plain loop: every owned particle in order (none lazy: all steps but the multi-rate
  // integrator's short ones), no damping limit, no sheared boundary. Without the per-row and
  // per-entry tests for those, the compiler keeps more of the loop in registers: the pair stage
  // of the 50k gas executes 14 % fewer instructions with friction and 18 % without
  // (scripts/bench-instructions), bitwise the same result.
  law_.with_parts([&](const auto& parts) {
    if (sim.stepping.all_targets && !limit_.on() && !sim.domain.shear.enabled) evaluate<true>(sim, parts);
    else evaluate<false>(sim, parts);
  });
}

// The pair loop, compiled once per combination of the law's parts (LawParts): a scene pays
// only for the parts it uses.
template <bool Plain, class Parts>
void ContactForces::evaluate(Simulation& sim, const Parts& parts) {
  ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  constexpr bool fric = Parts::friction;
  constexpr bool rolls = Parts::rolling;  // rolling and twisting resistance (friction is on)
  const bool advance = !sim.stepping.initial_forces;  // F(0) reads the springs; the steps move them
  if (fric && springs_.entries() != nl.size()) springs_.reset(nl.size(), rolls);
  long contacts = 0;
  double worst = 0;
  std::int64_t worst_id = -1;
  // Raw views: the compiler cannot prove the vectors' data pointers stay put across the
  // stores below, and would reload them for every pair.
  const Vec3* X = p.x.data();
  const Vec3* V = p.v.data();
  const Vec3* W = fric ? p.omega.data() : nullptr;
  const double* A = p.radius.data();
  const double* M = p.mass.data();
  const std::int32_t* S = p.species.data();
  const std::uint32_t* start = nl.start.data();
  const std::uint32_t* partner = nl.partner.data();
  std::uint32_t* HELD = fric ? springs_.slots() : nullptr;  // per entry: its springs' slot
  if (touching_.size() != nl.size()) refill(touching_, nl.size(), 0);
  std::uint8_t* T = touching_.data();
  const std::int64_t* ID = p.id.data();
  double overlap_sum = 0;
  long onsets = 0;
  // A pair of two owned particles is evaluated once, from its lower slot; the partner's entry
  // reads the result. The law is exactly antisymmetric (see LinearSpringDashpot), so this is
  // bitwise the same as evaluating both sides (pairs in split_ are evaluated on both sides).
  if (mirror_.size() != nl.size()) build_mirrors(p, nl);
  std::uint32_t* MIRROR = mirror_.data();
  constexpr bool keeps = fric || Parts::bridges;  // history on both entries of a pair: see split_
  const std::uint32_t* SPLIT = split_.data();
  Vec3* FORCE = p.f.data();
  Vec3* TORQUE = fric ? p.torque.data() : nullptr;
  constexpr bool exact = Parts::exact;
  const double dt = law_.dt();
  // Bridges restitution: each contact's law follows from its impact speed, kept per entry.
  constexpr bool vdep = Parts::bridges;
  if (vdep && impact_.size() != nl.size()) refill(impact_, nl.size(), 0.0);
  double* U = vdep ? impact_.data() : nullptr;
  PairLaw contact_law;  // scratch for a contact's own law
  auto law_of = [&](int a, int b, std::uint32_t k) -> const PairLaw& {
    if (!vdep || !(law_.law(a, b).v_c > 0)) return law_.law(a, b);
    contact_law = law_.at_impact(a, b, U[k]);
    return contact_law;
  };
  // Crowded particles (DampingLimit): this step's loads, and dashpots scaled by last step's.
  const bool limit = !Plain && limit_.on();
  PairLaw limited_law;  // scratch for a contact whose dashpots are limited
  auto add_load = [&](std::size_t i, std::size_t j, const PairLaw& L) {
    const LinearSpringDashpot::Stability st = law_.stability(L);
    limit_.add(p, i, st.K, st.G, DampingLimit::weight(M[i], M[j]));
    if constexpr (rolls) {  // the torque springs on i's spin (solid spheres, I = 2/5 m a^2)
      const double mi = M[i], mj = M[j], ai = A[i], aj = A[j];
      const double ii = 0.4 * mi * ai * ai, ij = 0.4 * mj * aj * aj;
      const LinearSpringDashpot::Stability spin =
          law_.spin_stability(L, mi * mj / (mi + mj) * L.k_per_mass, ai * aj / (ai + aj),
                              1 / (1 / (1.4 * mi * ai * ai) + 1 / (1.4 * mj * aj * aj)), 1 / ii + 1 / std::sqrt(ii * ij));
      limit_.add(p, i, spin.K, spin.G, 1.0);
    }
  };
  shifts_.clear();
  // A contact with a partner's image across a Lees-Edwards boundary does work at the image's
  // velocity jump +-gamma_dot L_y: the boundary's share of the shear work (the rest comes with
  // particles crossing, HaloExchange::shear_energy). Half on each side of the pair.
  const bool sheared = !Plain && sim.domain.shear.enabled;
  const double half_jump_dt = sheared ? 0.5 * sim.domain.shear.rate * sim.domain.length[1] * dt : 0.0;
  double boundary_work = 0;
  if (sheared && image_side_.size() != p.nghost())
    throw std::logic_error("ContactForces: ghosts changed without a rebuild (image sides unknown)");
  const std::int8_t* SIDE = sheared ? image_side_.data() - p.nlocal : nullptr;  // a ghost's side, by its slot
  auto across = [&](std::uint32_t j) { return double(SIDE[j]); };
  // Ascending slots (all, or the multi-rate integrator's targets): a pair's result is written
  // before its partner's entry reads it.
  const Simulation::TargetList targets = sim.target_list();
  // Between the multi-rate integrator's long steps, a free particle's stored state is that of
  // an earlier time: it is skipped (it is woken before it can touch anything).
  const double* LAZY = Plain || sim.stepping.lazy_column < 0 ? nullptr : p.module_columns[sim.stepping.lazy_column].data.data();
  // Three passes, none of whose few branches a gas can predict badly (cachegrind --branch-sim;
  // with ~1.7 entries a row and one in eight touching, a single loop mispredicted about one
  // branch per entry, and a mispredicted branch behind a contact's long chain of square roots
  // and divisions threw away the overlap of the next contacts' work):
  //  1. list the entries with work: in contact now (the same test from either side of a pair:
  //     d negated exactly, the same r^2 and a_i + a_j) or at the last evaluation (an exit); and
  //     among them those that evaluate their pair (partner above, or a ghost);
  //  2. evaluate those, each into its own result slot (the partner's entry gets the slot's
  //     number, or a slot of its own when its side is evaluated apart: split_, Bridges);
  //  3. sum the listed entries' results row by row in list order: every sum is taken in the
  //     same order as by a single loop over the list.
  // The lists grow in chunks of entries, so they hold about the entries with work (one in five
  // in a gas) rather than one slot per entry: room for a whole chunk is made before it.
  constexpr std::size_t kChunk = 4096;
  auto room = [](std::vector<std::uint32_t>& list, std::size_t used, std::size_t more) {
    if (used + more > list.size()) list.resize(used + more + list.size() / 4);
    return list.data();
  };
  std::uint32_t* ACTIVE = nullptr;
  std::uint32_t* EVAL = nullptr;
  const std::uint32_t* ROW = nl.row.data();
  std::size_t nactive = 0, neval = 0;
  if constexpr (Plain) {
    const std::size_t entries = nl.size();
    for (std::size_t k0 = 0; k0 < entries; k0 += kChunk) {
      ACTIVE = room(active_, nactive, kChunk);
      EVAL = room(evaluating_, neval, kChunk);
      for (std::size_t k = k0, k1 = std::min(entries, k0 + kChunk); k < k1; ++k) {
        const std::uint32_t i = ROW[k], j = partner[k];
        const double R = A[i] + A[j];
        const bool work = (T[k] != 0) | ((X[i] - X[j]).squaredNorm() < R * R);
        ACTIVE[nactive] = EVAL[neval] = static_cast<std::uint32_t>(k);  // written always, kept when counted
        nactive += work;
        neval += work & (j >= i);  // j == i: a particle's own periodic image, evaluated
      }
    }
  } else {
    for (std::size_t t = 0; t < targets.count; ++t) {
      const std::size_t i = targets[t];
      ACTIVE = room(active_, nactive, start[i + 1] - start[i]);
      EVAL = room(evaluating_, neval, start[i + 1] - start[i]);
      for (std::uint32_t k = start[i]; k < start[i + 1]; ++k) {
        const std::uint32_t j = partner[k];
        if (LAZY && LAZY[j] == 0) continue;  // a free particle between long steps: not touching (MultiRateHill)
        const double R = A[i] + A[j];
        if (T[k] || (X[i] - X[j]).squaredNorm() < R * R) {
          ACTIVE[nactive++] = k;
          if (j >= i) EVAL[neval++] = k;
        }
      }
    }
  }
  // Pass 2. Slot e holds EVAL[e]'s result; slots past neval, the partner sides evaluated apart.
  results_.resize(neval);
  if (rolls) result_roll_.resize(neval);
  Result* RES = results_.data();
  Vec3* RROLL = rolls ? result_roll_.data() : nullptr;
  auto own_slot = [&] {  // rare: a partner side evaluated apart
    results_.emplace_back();
    if (rolls) result_roll_.emplace_back();
    RES = results_.data();
    RROLL = rolls ? result_roll_.data() : nullptr;
    return static_cast<std::uint32_t>(results_.size() - 1);
  };
  for (std::size_t e = 0; e < neval; ++e) {
    const std::uint32_t k = EVAL[e];
    const std::uint32_t i = ROW[k], j = partner[k];
    const std::uint32_t mk = MIRROR[k];  // kNoMirror for a ghost partner
    RES[e].flags = 0;
    const Vec3 xi = X[i];
    const double ai = A[i];
    const Vec3 d = xi - X[j];
    const double r2 = d.squaredNorm(), R = ai + A[j];
    if (r2 >= R * R) {  // contact just ended (listed for T[k]): forget the spring
      T[k] = 0;
      if (fric) springs_.release(HELD[k]);
      if (mk != kNoMirror) {
        T[mk] = 0;
        MIRROR[mk] = kNoMirror;  // no result, unless the exit correction below gives one
        if (fric) springs_.release(HELD[mk]);  // held only in split_
      }
      // The exact scheme's exit correction (see LinearSpringDashpot): only a pair that
      // touched at the last evaluation can have parted during the step.
      if (exact) {
        const Vec3 vi = V[i];
        const double mi = M[i];
        const int si = S[i];
        const double r = std::sqrt(r2);
        const Vec3 n = d * (1 / r);
        const double mj = M[j];
        const double m = mi * mj / (mi + mj);
        const double vn = (vi - V[j]).dot(n);
        const double reff = Parts::reduced_radius ? ai * A[j] / (ai + A[j]) : 0.0;
        const NormalStep ns = law_.normal(parts, law_of(si, S[j], k), m, R - r, vn, reff);
        if (ns.fn != 0 || ns.shift != 0) {
          const Vec3 f = ns.fn * n;
          RES[e].f = f;
          RES[e].shift = ns.shift;
          RES[e].flags = kHasForce;
          if (sheared && mk == kNoMirror) boundary_work += across(j) * f[0] * half_jump_dt;
        }
        if (mk != kNoMirror) {  // j's side: negated, or on its own impact speed (see below)
          const bool own_law = vdep && U[mk] != U[k];
          const NormalStep nj = own_law ? law_.normal(parts, law_of(S[j], si, mk), m, R - r, vn, reff) : ns;
          if (nj.fn != 0 || nj.shift != 0) {
            std::uint32_t slot = static_cast<std::uint32_t>(e);
            if (own_law) {
              slot = own_slot();
              RES[slot].f = nj.fn * n;  // read negated
              RES[slot].shift = nj.shift;
              RES[slot].flags = kHasForce;
            }
            MIRROR[mk] = slot;
          }
        }
      }
      if (vdep) {
        U[k] = 0;
        if (mk != kNoMirror) U[mk] = 0;
      }
      continue;
    }
    // A ghost pair is counted by the lower id, wherever it lives; an owned pair once, here.
    const bool onset = !T[k] && (mk != kNoMirror || ID[i] < ID[j]);
    onsets += onset;
    const bool fresh = !T[k];  // not touching at the last evaluation
    T[k] = 1;
    const Vec3 vi = V[i];
    const double mi = M[i];
    const int si = S[i];
    const double r = std::sqrt(r2);
    const Vec3 n = d * (1 / r);  // one division, not three; exactly negated from j's side
    const double delta = R - r;
    const double mj = M[j];
    const double m = mi * mj / (mi + mj);
    Vec3 vrel = vi - V[j];
    // The impact speed u of the free approach (the velocity of the last step). A contact found
    // touching without a recorded impact (initial overlaps, a snapshot from before impact
    // speeds were stored) takes its present approach speed.
    if (vdep && (fresh || U[k] == 0)) U[k] = std::max(-vrel.dot(n), 0.0);
    const PairLaw& L0 = law_of(si, S[j], k);
    const double damping = limit ? std::min(limit_.scale(p, i), limit_.scale(p, j)) : 1.0;
    const PairLaw& L = damping < 1 ? (limited_law = LinearSpringDashpot::damped(L0, damping)) : L0;
    if (onset) {
      const double u = -vrel.dot(n), e_ = L.e;
      impact_loss_ += 0.5 * (1 - e_ * e_) * m * u * u;
      impact_virial_ += ((1 + e_) * m * u * R) * (n * n.transpose());
    }
    // The lower id's term first: a fused multiply-add rounds the other product, so a fixed
    // order is what makes the two sides' results exact negatives of each other.
    if (fric) vrel -= (ID[i] < ID[j] ? ai * W[i] + A[j] * W[j] : A[j] * W[j] + ai * W[i]).cross(n);
    Vec3 ft;
    // A pair whose history came from two independent evaluations (split_) has j's side
    // evaluated on its own spring, as j would; any other owned pair's is the exact negative.
    bool split = false;
    if (keeps && mk != kNoMirror) {
      while (*SPLIT < k) ++SPLIT;  // the listed entries come in ascending order
      split = *SPLIT == k;
    }
    double shift = 0;
    const double reff = Parts::reduced_radius ? ai * A[j] / (ai + A[j]) : 0.0;  // reduced radius
    // Rolling: relative spin and reduced moment of inertia about the contact point (I + m a^2
    // = 1.4 m a^2 per solid sphere; ghosts carry no inverse inertia).
    const std::uint32_t held = fric ? springs_.hold(HELD[k]) : 0;
    Rolling rl;
    if (rolls) rl = {W[i] - W[j], 1 / (1 / (1.4 * mi * ai * ai) + 1 / (1.4 * mj * A[j] * A[j])), springs_.roll(held)};
    const Vec3 f = law_.force(parts, L, m, delta, n, vrel, fric ? &springs_.xi(held) : nullptr, ft, advance, &shift, reff,
                              rolls ? &rl : nullptr);
    if (rolls) springs_.roll(held) = rl.spring;
    if (sheared && mk == kNoMirror) boundary_work += across(j) * f[0] * half_jump_dt;
    // The lever arm's cross product, shared by both sides: j's, (-n) x (-f_t), is the same bits.
    Result& res = RES[e];
    res.f = f;
    res.shift = shift;
    res.flags = kHasForce | kContact;
    if (fric) res.nxft = n.cross(ft);
    if (rolls) RROLL[e] = rl.torque;
    // The diagnostics, for both owned sides of a pair at once (the same overlap either way).
    const int sides = mk != kNoMirror ? 2 : 1;
    contacts += sides;
    const double frac = delta / std::min(ai, A[j]);
    overlap_sum += sides * frac;
    if (frac > worst) { worst = frac; worst_id = std::min(ID[i], ID[j]); }
    if (mk != kNoMirror) {  // j's side: every quantity negated, exactly as j would compute it
      T[mk] = 1;
      // Impact speeds recorded by an independent two-sided evaluation (across a periodic
      // boundary before a migration; the image's coordinates round differently) may differ
      // in the last bits, as springs may: then j's side is evaluated on its own, as j would.
      if (vdep && (fresh || U[mk] == 0)) U[mk] = U[k];
      const bool own_law = vdep && U[mk] != U[k];  // only in split_ (found with the springs)
      std::uint32_t slot = static_cast<std::uint32_t>(e);
      if (split || own_law) {
        const Vec3 nj = -n;
        Vec3 ftj;
        const PairLaw Lj = !own_law ? L : damping < 1 ? LinearSpringDashpot::damped(law_of(S[j], si, mk), damping)
                                                      : law_of(S[j], si, mk);
        const std::uint32_t held_j = fric ? springs_.hold(HELD[mk]) : 0;
        Rolling rj;
        if (rolls) rj = {-rl.spin, rl.inertia, springs_.roll(held_j)};
        double shift_j = 0;
        const Vec3 fj = law_.force(parts, Lj, m, delta, nj, -vrel, fric ? &springs_.xi(held_j) : nullptr, ftj, advance,
                                   &shift_j, reff, rolls ? &rj : nullptr);
        if (rolls) springs_.roll(held_j) = rj.spring;
        slot = own_slot();
        RES[slot].f = -fj;  // read negated
        RES[slot].shift = shift_j;
        RES[slot].flags = kHasForce | kContact;
        if (fric) RES[slot].nxft = nj.cross(ftj);
        if (rolls) RROLL[slot] = -rj.torque;  // read negated
      }
      MIRROR[mk] = slot;
    }
  }
  // Pass 3: the rows' sums, in list order. A receiving entry (partner below) reads its pair's
  // slot negated; its move is rebuilt as its own side would (rare: onset and exit steps).
  std::size_t i = p.nlocal;  // none yet
  Vec3 xi = Vec3::Zero(), fsum = Vec3::Zero(), tsum = Vec3::Zero(), dsum = Vec3::Zero();
  double ai = 0;
  bool touched = false, moved = false;
  auto end_row = [&] {
    if (touched) {
      FORCE[i] += fsum;
      if (fric) TORQUE[i] += tsum;
    }
    if (exact && moved) shifts_.add(i, dsum);
  };
  std::size_t e = 0;
  const Result none{Vec3::Zero(), Vec3::Zero(), 0.0, 0};
  for (std::size_t a = 0; a < nactive; ++a) {
    const std::uint32_t k = ACTIVE[a];
    if (ROW[k] != i) {
      if (i < p.nlocal) end_row();
      i = ROW[k];
      xi = X[i];
      ai = A[i];
      fsum.setZero();
      tsum.setZero();
      dsum.setZero();
      touched = moved = false;
    }
    const std::uint32_t j = partner[k];
    // Selects, not branches: which side an entry is on follows no pattern.
    const bool receiving = j < i;
    const std::uint32_t slot = receiving ? MIRROR[k] : static_cast<std::uint32_t>(e);
    e += !receiving;
    const Result& r = *(slot == kNoMirror ? &none : RES + slot);
    if (!(r.flags & kHasForce)) continue;  // parted without a force
    const double sign = receiving ? -1.0 : 1.0;
    fsum += sign * r.f;  // negation is exact
    touched = true;
    if (r.shift != 0) {  // i's part of the pair's move, along i's own normal
      const Vec3 d = xi - X[j];
      const Vec3 n = d * (1 / std::sqrt(d.squaredNorm()));
      const double mi = M[i], mj = M[j];
      const double m = mi * mj / (mi + mj);
      dsum += (-(m / mi) * r.shift) * n;
      moved = true;
    }
    if (!(r.flags & kContact)) continue;  // the exact scheme's exit step: a force, not a contact
    if (fric) tsum += rolls ? Vec3(-ai * r.nxft + sign * RROLL[slot]) : Vec3(-ai * r.nxft);
    if (limit) add_load(i, j, law_of(S[i], S[j], k));
  }
  if (i < p.nlocal) end_row();
  contacts_ = contacts;
  boundary_work_ += boundary_work;
  overlap_sum_ = overlap_sum;
  collisions_ += onsets;
  max_overlap_ = worst;
  worst_id_ = worst_id;
}

void ContactForces::final_integrate(Simulation& sim) {
  shifts_.apply(sim.particles);
  const Simulation::TargetList t = sim.target_list();
  limit_.finish_step(sim.particles, t.list, t.count, sim.rebuilds);
}

double ContactForces::elastic_energy(const Simulation& sim) const {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  const bool springs = has_springs(nl);
  double e = 0;
  nl.for_each_overlap(p, false, [&](const NeighborList::Overlap& c) {
    const std::size_t i = c.i, j = c.j, k = c.k;
    const double m = p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
    const Springs s = springs ? spring_of(p, nl, k) : Springs{};
    e += 0.5 * law_.spring_energy(entry_law(p.species[i], p.species[j], k), m, c.delta,
                                  p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]), c.n,
                                  springs ? &s.xi : nullptr, springs && law_.rolling() ? &s.roll : nullptr);  // half per side
  });
  return e;
}

void ContactForces::in_contact(std::vector<std::uint32_t>& out) const {
  std::size_t n = 0;
  for (const std::uint8_t t : touching_) n += t != 0;
  out.resize(n + 1);  // the loop below writes one past the last entry it keeps
  n = 0;
  for (std::size_t k = 0; k < touching_.size(); ++k) {  // no branch: one entry in eight touches
    out[n] = static_cast<std::uint32_t>(k);
    n += touching_[k] != 0;
  }
  out.resize(n);
}

ContactForces::Springs ContactForces::spring_of(const ParticleStore& p, const NeighborList& nl, std::uint32_t k) const {
  const auto held = [&](std::uint32_t slot, double sign) {
    Springs s;
    s.xi = sign * springs_.xi(slot);  // negation is exact
    if (law_.rolling()) s.roll = sign * springs_.roll(slot);
    return s;
  };
  if (springs_.slot(k) != ContactSprings::kNone) return held(springs_.slot(k), 1.0);
  const std::uint32_t i = nl.row[k], j = nl.partner[k];
  if (j >= i || j >= p.nlocal) return {};  // an evaluating entry out of contact, or a ghost pair's
  for (std::uint32_t q = nl.start[j]; q < nl.start[j + 1]; ++q)  // the pair's evaluating entry
    if (nl.partner[q] == i) return springs_.slot(q) != ContactSprings::kNone ? held(springs_.slot(q), -1.0) : Springs{};
  return {};
}

void ContactForces::contact_history(const Simulation& sim, PairHistory& out) const {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  if (nl.start.size() != p.nlocal + 1 || touching_.size() != nl.size()) return;
  const bool fric = has_springs(nl);
  const bool vdep = law_.velocity_dependent() && impact_.size() == nl.size();
  std::vector<std::uint32_t> entries;
  in_contact(entries);
  for (const std::uint32_t k : entries) {
    const Springs s = fric ? spring_of(p, nl, k) : Springs{};
    const double u = vdep ? impact_[k] : 0.0;
    if (s.xi.isZero(0) && u == 0 && s.roll.isZero(0)) continue;
    double* row = out.add(p.id[nl.row[k]], p.id[nl.partner[k]]);
    if (xi_column_ >= 0) std::copy_n(s.xi.data(), 3, row + xi_column_);
    if (impact_column_ >= 0) row[impact_column_] = u;
    if (roll_column_ >= 0) std::copy_n(s.roll.data(), 3, row + roll_column_);
  }
}

PairLaw ContactForces::entry_law(int a, int b, std::uint32_t k) const {
  if (!(law_.law(a, b).v_c > 0) || k >= impact_.size()) return law_.law(a, b);
  return law_.at_impact(a, b, impact_[k]);
}

void ContactForces::pair_forces(const Simulation& sim, std::vector<PairForce>& out) const {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  const bool fric = law_.friction(), springs = has_springs(nl);
  nl.for_each_overlap(p, true, [&](const NeighborList::Overlap& c) {
    const std::size_t i = c.i, j = c.j, k = c.k;
    const double m = p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
    Vec3 vrel = p.v[i] - p.v[j];
    if (fric) vrel -= (p.radius[i] * p.omega[i] + p.radius[j] * p.omega[j]).cross(c.n);  // id[i] < id[j], as in force()
    Vec3 spring = springs ? spring_of(p, nl, k).xi : Vec3::Zero(), ft;
    // The step already advanced the spring: report it as it stands (no second increment).
    const Vec3 f = law_.force(entry_law(p.species[i], p.species[j], k), m, c.delta, c.n, vrel, fric ? &spring : nullptr,
                              ft, false, nullptr, p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]));
    out.push_back({p.id[i], p.id[j], p.x[i], c.d, f});
  });
}

ModuleKind ContactForces::kind() {
  return {"contact", {}, nullptr, [](Simulation& sim) {
            auto c = std::make_unique<ContactForces>(sim.cfg, sim.dt);
            if (c->law_.damping_limit()) c->limit_ = DampingLimit::attach(sim.particles);
            if (c->law_.friction()) c->xi_column_ = sim.history.declare("xi", 3);
            if (c->law_.velocity_dependent()) c->impact_column_ = sim.history.declare("impact_speed", 1);
            if (c->law_.rolling()) c->roll_column_ = sim.history.declare("roll", 3);
            return c;
          }};
}

void ContactForces::observables(Simulation& sim, std::vector<std::pair<std::string, double>>& out) {
  const double local[3] = {double(contacts_), double(take_collisions()), overlap_sum_};
  double sums[3], worst = 0;
  MPI_Allreduce(local, sums, 3, MPI_DOUBLE, MPI_SUM, sim.domain.comm);
  MPI_Allreduce(&max_overlap_, &worst, 1, MPI_DOUBLE, MPI_MAX, sim.domain.comm);
  out.insert(out.end(), {{"contacts", sums[0] / 2},  // each pair counted on both owned sides
                         {"collisions", sums[1]},
                         {"mean_overlap_over_radius", sums[0] > 0 ? sums[2] / sums[0] : 0.0},
                         {"max_overlap_over_radius", worst}});
}

namespace {
// A Hertz contact is shorter the faster the impact (t_c ~ u^-1/5), and dt follows from the
// species' impact_speed, "the fastest expected". Particles that start far faster than that
// would collide under-resolved from the first step: refuse, naming the key.
void refuse_impacts_faster_than_expected(const Simulation& sim) {
  const Config& cfg = sim.cfg;
  const ParticleStore& p = sim.particles;
  std::vector<double> fastest(cfg.species.size(), 0.0), global(cfg.species.size(), 0.0);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    double& f = fastest[p.species[i]];
    f = std::max(f, (p.v[i] - sim.imposed_flow(p.x[i])).norm());
  }
  MPI_Allreduce(fastest.data(), global.data(), int(fastest.size()), MPI_DOUBLE, MPI_MAX, sim.domain.comm);
  for (std::size_t k = 0; k < cfg.species.size(); ++k) {
    const SpeciesLaw& s = cfg.get<ContactSettings>().species[k];
    const double approach = 2 * global[k];  // two such particles head-on
    if (!(s.impact_speed > 0) || approach <= 10 * s.impact_speed || cfg.force_dt) continue;
    std::ostringstream os;
    os << cfg.source << ": key 'species[" << k << "].impact_speed': " << s.impact_speed
       << " m/s, but the initial particles approach at up to " << approach << " m/s, where a contact lasts "
       << s.t_c * std::pow(s.impact_speed / approach, 0.2) / sim.dt << " steps instead of " << s.t_c / sim.dt
       << "; expected an impact speed of at least a tenth of that (or time.force = true)";
    throw ConfigError(os.str());
  }
}
}  // namespace

void ContactForces::setup(Simulation& sim) {
  if (sim.restored) refresh_diagnostics(sim);
  else refuse_impacts_faster_than_expected(sim);
}

void ContactForces::refresh_diagnostics(const Simulation& sim) {
  const ParticleStore& p = sim.particles;
  contacts_ = 0;
  max_overlap_ = overlap_sum_ = 0;
  // As force() counts them: each overlapping pair from its evaluating entry, in list order.
  sim.neighbors.for_each_overlap(p, false, [&](const NeighborList::Overlap& c) {
    if (c.j < c.i) return;  // an owned pair's receiving entry
    const int sides = c.j < p.nlocal ? 2 : 1;
    contacts_ += sides;
    const double frac = c.delta / std::min(p.radius[c.i], p.radius[c.j]);
    overlap_sum_ += sides * frac;
    if (frac > max_overlap_) { max_overlap_ = frac; worst_id_ = std::min(p.id[c.i], p.id[c.j]); }
  });
}

void ContactForces::build_mirrors(const ParticleStore& p, const NeighborList& nl) {
  // Lists are symmetric for owned pairs (same cut-off from both sides) and short.
  refill(mirror_, nl.size(), kNoMirror);
  split_.assign(1, kSplitEnd);  // none (post_rebuild finds them)
  nl.for_each_pair([&](std::size_t i, std::uint32_t j, std::uint32_t k) {
    if (j <= i || j >= p.nlocal) return;
    for (std::uint32_t q = nl.start[j]; q < nl.start[j + 1]; ++q)
      if (nl.partner[q] == i) {
        mirror_[k] = q;  // the evaluating entry: the partner's entry (the partner's own: force())
        break;
      }
    if (mirror_[k] == kNoMirror) throw std::logic_error("ContactForces: neighbour list is not symmetric");
  });
}

void ContactForces::pre_rebuild(Simulation& sim) {
  // Without a list yet (first rebuild, or after a restart) keep what is in the stash.
  if (!keeps_history() || sim.neighbors.start.size() != sim.particles.nlocal + 1) return;
  sim.history.clear();
  contact_history(sim, sim.history);
}

namespace {
// Open addressing over the stash's (owner, partner) ids: each touching entry finds its history
// in about one probe, where sorting the stash and searching it per particle cost several times
// the rest of post_rebuild (mispredicted branches, in a gas of one contact per particle or so).
std::uint64_t pair_hash(std::int64_t owner, std::int64_t partner) {
  std::uint64_t h = static_cast<std::uint64_t>(owner) * 0x9E3779B97F4A7C15ull;
  h ^= static_cast<std::uint64_t>(partner) + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2);
  return h * 0xD6E8FEB86659FD93ull;
}
constexpr std::uint32_t kEmpty = 0xffffffffu;
}  // namespace

void ContactForces::post_rebuild(Simulation& sim) {
  const ParticleStore& p = sim.particles;
  const NeighborList& nl = sim.neighbors;
  build_mirrors(p, nl);
  // Which ghosts are images across the sheared boundary: now, with every owned particle inside
  // the box, an image is outside it. Between rebuilds particles drift past the faces (they are
  // wrapped at the next migration), so a ghost's position then no longer tells.
  image_side_.clear();
  if (sim.domain.shear.enabled)
    for (std::size_t j = p.nlocal; j < p.size(); ++j)
      image_side_.push_back(p.x[j][1] >= sim.domain.hi[1] ? 1 : p.x[j][1] < sim.domain.lo[1] ? -1 : 0);
  // Pairs already touching across a rebuild are not new collisions.
  refill(touching_, nl.size(), 0);
  touching_now_.clear();
  nl.for_each_pair([&](std::size_t i, std::uint32_t j, std::uint32_t k) {
    if (j < i) return;  // an owned pair: set from its lower slot, below
    const double R = p.radius[i] + p.radius[j];
    const Vec3 d = p.x[i] - p.x[j];
    // The exact scheme needs to know which pairs touched a step ago (to correct their exit,
    // and so that a contact that began in this step is still counted as a collision): from
    // the state, delta + v_n dt > 0. Rebuilds happen at the same steps on any number of ranks
    // and at every snapshot, so this keeps runs rank-independent and restart-exact.
    bool touch;
    if (law_.exact()) {
      // Farther apart than the pair can close in a step (|v| <= the sum of its components',
      // with room for rounding): apart a step ago too, without the square root and division.
      const Vec3 v = p.v[i] - p.v[j];
      const double reach = R + (std::abs(v[0]) + std::abs(v[1]) + std::abs(v[2])) * law_.dt() * (1 + 1e-9) + 1e-12 * R;
      if (d.squaredNorm() > reach * reach) {
        touch = false;
      } else {
        const double r = d.norm();
        touch = R - r + v.dot(d / r) * law_.dt() > 0;
      }
    } else {
      touch = d.squaredNorm() < R * R;
    }
    touching_[k] = touch;
    // The partner's entry: d and v_i - v_j negated exactly, the same operations, the same answer.
    if (mirror_[k] != kNoMirror) touching_[mirror_[k]] = touch;
    if (touch) touching_now_.push_back(k);
  });
  if (!keeps_history()) return;
  auto& stash = sim.history;
  const bool fric = law_.friction(), vdep = law_.velocity_dependent(), rolls = law_.rolling();
  if (fric) springs_.reset(nl.size(), rolls);
  if (vdep) refill(impact_, nl.size(), 0.0);
  // The stash hashed by (owner, partner), at most half full; of equal keys (a small periodic box
  // can list one partner twice) the first.
  std::size_t size = 64;
  while (size < 2 * stash.size()) size *= 2;
  const std::uint64_t mask = size - 1;
  table_.assign(size, kEmpty);
  for (std::uint32_t at = 0; at < stash.size(); ++at) {
    for (std::uint64_t h = pair_hash(stash.owner[at], stash.partner[at]) & mask;; h = (h + 1) & mask) {
      const std::uint32_t q = table_[h];
      if (q == kEmpty) { table_[h] = at; break; }
      if (stash.owner[q] == stash.owner[at] && stash.partner[q] == stash.partner[at]) break;
    }
  }
  // A contact's history as it arrived: its row's columns, zeros for a new contact.
  struct Arrived {
    Vec3 xi = Vec3::Zero(), roll = Vec3::Zero();
    double impact = 0;
  };
  auto find = [&](std::int64_t owner, std::int64_t partner) {
    Arrived a;
    for (std::uint64_t h = pair_hash(owner, partner) & mask;; h = (h + 1) & mask) {
      const std::uint32_t q = table_[h];
      if (q == kEmpty) return a;  // a new contact (or one that began in the drift)
      if (stash.owner[q] == owner && stash.partner[q] == partner) {
        const double* row = stash.row(q);
        if (xi_column_ >= 0) a.xi = Vec3(row[xi_column_], row[xi_column_ + 1], row[xi_column_ + 2]);
        if (roll_column_ >= 0) a.roll = Vec3(row[roll_column_], row[roll_column_ + 1], row[roll_column_ + 2]);
        if (impact_column_ >= 0) a.impact = row[impact_column_];
        return a;
      }
    }
  };
  std::uint32_t* held = springs_.slots();
  auto restore = [&](std::uint32_t k, const Arrived& e) {
    if (vdep) impact_[k] = e.impact;
    if (!fric) return;
    const std::uint32_t slot = springs_.hold(held[k]);
    springs_.xi(slot) = e.xi;
    if (rolls) springs_.roll(slot) = e.roll;
  };
  // Touching pairs only (a spring separated during the drift is gone), both sides of an owned
  // pair, then the pairs whose two sides did not arrive as exact negatives (see split_).
  split_.clear();
  for (const std::uint32_t k : touching_now_) {
    const std::uint32_t i = nl.row[k], j = nl.partner[k], q = mirror_[k];
    const Arrived a = find(p.id[i], p.id[j]);
    restore(k, a);
    if (q == kNoMirror) continue;
    const Arrived b = find(p.id[j], p.id[i]);
    if (vdep) impact_[q] = b.impact;
    if ((fric && b.xi != -a.xi) || (rolls && b.roll != -a.roll) || (vdep && b.impact != a.impact)) {
      split_.push_back(k);
      restore(q, b);  // its own springs (only the evaluating entry's otherwise)
    }
  }
  split_.push_back(kSplitEnd);
  stash.clear();
}

}  // namespace cassini
