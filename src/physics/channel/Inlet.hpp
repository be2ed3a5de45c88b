#pragma once
// Particle insertion at the channel's inlet (spec section 3): every inlet.every seconds the
// insertion zone (inlet.x +- inlet.length/2, the full cross-section) is topped up to the
// volume fraction inlet.volume_fraction with particles at random positions that overlap no
// particle and no wall, moving with the local fluid velocity. Every rank draws the same
// candidates from the case's seed and the step number, and tests them against the same
// gathered set of nearby particles (sorted by id), so insertion does not depend on the rank
// count. The outlet is the domain's open x face: particles that leave are removed and counted.
// inlet.prefill: at the start the channel is filled the same way from the zone to the neck's exit.
#include "core/Config.hpp"
#include "core/Module.hpp"
#include "core/ModuleRegistry.hpp"
#include "physics/channel/ChannelConfig.hpp"
#include "physics/channel/ChannelGeometry.hpp"

namespace cassini {

class Inlet : public Module {
 public:
  static ModuleKind kind();
  Inlet(const Config& cfg, const ChannelGeometry& geo) : cfg_(cfg), geo_(geo) {}
  std::string name() const override { return "inlet (phi = " + std::to_string(cfg_.get<ChannelConfig>().inlet_fraction).substr(0, 4) + ")"; }
  unsigned stages() const override { return kEndOfStep; }
  void setup(Simulation& sim) override;
  void end_of_step(Simulation& sim) override;
  long inserted() const { return inserted_; }
  double energy_input() const override { return added_energy_; }  // kinetic energy brought in
  long failed_top_ups() const { return short_; }
  // The last top-up found the zone at its target: as long as nothing moves, none will insert.
  bool full() const { return full_; }
  void save_state(std::vector<std::pair<std::string, double>>& out) const override {
    out.insert(out.end(), {{"inlet.next_id", double(next_id_)}, {"inlet.inserted", double(inserted_)},
                           {"inlet.failed_top_ups", double(short_)}});
  }

 private:
  void top_up(Simulation& sim);
  // Tops up x0 <= x < x0 + length (the full cross-section) to the inlet's volume fraction, drawing from
  // random stream `stream` of the case's seed (a top-up's: its step + 1; the prefill's: 0).
  // Gives up after inlet.attempts candidates, or (patient) after that many failures in a row.
  // True if it was already there.
  bool fill(Simulation& sim, double x0, double length, std::uint64_t stream, bool patient);
  const Config& cfg_;
  const ChannelGeometry& geo_;
  long every_ = 1;
  std::int64_t next_id_ = 0;
  long inserted_ = 0, short_ = 0;
  double added_energy_ = 0;
  bool full_ = false;
};

}  // namespace cassini
