#pragma once
// The modules a case can name, and how each one reads its case-file table and is made. The
// table is defined in physics/Registry.cpp, the one file that names concrete modules; the
// core knows them only through it. A module's kind lives in the module's own file.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <mpi.h>

#include "core/Module.hpp"

namespace cassini {

class CaseFile;
struct Config;
class Simulation;

struct ModuleKind {
  std::string name;                // as listed in the case file's `modules` (or time.integrator)
  std::vector<std::string> needs;  // modules that must be listed with it
  // Reads the module's own tables into the Config: its settings (Config::set) and what the
  // core must know (Config::pair_reach, halo_reach, frame_rotation, obstacle_radius). Runs
  // after the domain, species and module list are read, in table order. May be empty.
  std::function<void(CaseFile&, Config&)> read;
  // Makes the module for a run, once every module before it in the table is made (so it may
  // find them: Simulation::find) and declares its per-particle columns (ParticleStore::declare;
  // a wall module's springs: WallHistory).
  std::function<std::unique_ptr<Module>(Simulation&)> make;
  // Work every run of an ensemble shares, done once by all ranks together before the runs (the
  // drag's flow solve, which the runs then read from its cache). May be empty.
  std::function<void(const Config&, MPI_Comm)> prepare;
};

// Every module a case can list, in the order their forces are summed (part of what makes runs
// reproducible).
const std::vector<ModuleKind>& module_kinds();
// The time integrators (time.integrator), first the default. Their `read` runs after the time
// table; the integrator is the first module of every run.
const std::vector<ModuleKind>& integrator_kinds();
// The numerical guards, the last module of every run (they see every module's energy).
std::unique_ptr<Module> make_guards(Simulation& sim);

}  // namespace cassini
