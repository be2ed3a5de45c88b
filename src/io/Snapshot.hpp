#pragma once
// Particle snapshots in the H5MD 1.1 layout, one file per frame (snap_<step>.h5md), written
// collectively with parallel HDF5: every rank writes its own rows (no gather to rank 0).
// Rows are ordered by particle id whatever the rank count: particles are first redistributed
// into id blocks. A frame is written under a temporary name and renamed when complete, so a
// killed run leaves only complete frames that look complete.
//
// Layout (h5py: f["particles/grains/position/value"][0]):
//   h5md/                          version [1,1], author, creator
//   particles/grains/{position, velocity, omega*, id, species, radius, mass}/{step,time,value}
//   particles/trajectory           soft link to particles/grains (MDAnalysis looks for that name)
//   particles/grains/{force, torque*, body_force}/{step,time,value}   forces of the step;
//                                  body_force: the non-contact part (gravity, drag, frame forces)
//   particles/grains/<module column>/{step,time,value}   what modules declared per particle
//                                  (ParticleStore::declare): e.g. the wall modules' springs
//                                  plane_wall_xi, channel_wall_impact, moonlet_roll (WallHistory;
//                                  older snapshots: wall_xi, wall_impact, wall_roll, shared)
//   particles/grains/box           dimension, boundary; edges/{step,time,value[1][3][3]}
//   particles/grains/lees_edwards/{offset,direction,normal}/{step,time,value}   (sheared runs)
//   contacts/{owner, partner, <column>...}   contact history, one row per contact, a dataset per
//                                  column the contact law declared (core/PairHistory.hpp): xi
//                                  (friction), impact_speed (Bridges law), roll (rolling
//                                  resistance); restart needs them
//   contacts/{pair_ids, position_i, branch, force}   pair forces, each pair once (contacts and
//                                  lubrication), at the snapshot state: for stress (cassini-cg)
//   contacts/{wall_particle, wall_point, wall_branch, wall_force}   particle-wall contacts
//   parameters/                    case (resolved TOML text), run_id, units
//   parameters/state/<name>        run state a restart restores (inlet ids, clog timer, outlet counts)
//   results                        attributes: the run's results so far (as in summary.json)
// (* on grains: only when the scene rotates)
#include <string>

namespace cassini {

class Simulation;
class CaseFile;

// Refuses (ConfigError naming the key and both values) to continue `snapshot` with a case that
// does not describe its particles: every key must match the case stored in the snapshot except
// those a restart may change: time.end, output.*, guards.*, time.force, and the parallel layout
// (domain.slab_axis, domain.decomposition, domain.balance_every). Also refuses a missing file.
void check_restart_case(const std::string& snapshot, const CaseFile& now);

// A string attribute of a snapshot's parameters group ("" when absent: older snapshots).
std::string snapshot_parameter(const std::string& snapshot, const std::string& name);
// The resolved case text stored in a snapshot (parameters/case); throws if there is none.
std::string snapshot_case_text(const std::string& snapshot);

// Writes the current state of `sim` to dir/snap_<step>.h5md; returns the file name. run_id
// names the run (kept across restarts), so that cassini-cg can refuse to mix runs.
std::string write_snapshot(Simulation& sim, const std::string& dir, const std::string& case_text,
                           const std::string& run_id = "");

// Replaces the particles of a freshly constructed (not yet set up) simulation by those of a
// snapshot, with contact history, step, time and shear offset. Collective.
void read_snapshot(Simulation& sim, const std::string& file);

}  // namespace cassini
