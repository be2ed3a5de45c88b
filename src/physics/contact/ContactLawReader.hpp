#pragma once
// What a case file says about the contact law, read beside the law rather than by the generic
// case reader (io/ReadConfig.cpp calls these in its order): each [[species]]'s law keys, the
// [[pair]] tables and the mixing of unlike pairs, the [contact] table's scheme keys, and the
// time step, which the stiffest pair and the scheme's stability limit decide. A bad value
// throws ConfigError naming the key and what was expected. The keys: docs/case-file.md.
#include <string>

#include "core/CaseFile.hpp"
#include "core/Config.hpp"
#include "physics/contact/ContactSettings.hpp"

namespace cassini {

// The law keys of species table `prefix` ("species[i].") as the next species of c's
// ContactSettings; its geometry (density, radii) is read first, for Hertz's contact time. The
// law's parts' declared parameters included.
void read_species_law(CaseFile& f, const std::string& prefix, const Species& geometry, Config& c);
// Every pair's parameters: like pairs their species' own, unlike pairs mixed, [[pair]] tables
// overriding. Sets Config::rotation (some contact has friction).
void read_pair_laws(CaseFile& f, Config& c);
// contact.scheme (recorded in Config::recorded_settings), contact.clip_normal,
// contact.damping_limit.
void read_contact_table(CaseFile& f, Config& c);
// time.dt, or time.n_c against the stiffest pair's t_c; time.force; refused beyond the scheme's
// stability limit.
void read_time_step(CaseFile& f, Config& c);

}  // namespace cassini
