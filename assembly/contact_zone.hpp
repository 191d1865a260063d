// The contact zone (docs/theory/newton.md, "The contact zone's exact correction"): the
// particles with a contact pair, grown by layers of the bond preconditioner's stencil. The
// matrix-free Krylov solver solves P's rows of the zone exactly after each V-cycle.
#pragma once

#include <vector>

#include "contact/contact.hpp"
#include "core/types.hpp"
#include "discretisation/model.hpp"

namespace peristat {

struct ContactZoneOptions {
  int layers = 0;       ///< rings of the stencil around the contact particles (0: no zone)
  double cap = 0.0;     ///< the zone stops growing past this fraction of the particles
  double radius = 0.0;  ///< the stencil's radius (the bond preconditioner's, in metres)
};

/// Per particle, 1 in the zone and 0 outside: the particles with a candidate contact pair
/// (whatever its status), then `layers` times every bond neighbour within `radius` of a zone
/// particle, stopping before a layer that would take the zone past cap x the particles.
/// Empty when the zone would be empty, or when the contact particles alone pass the cap.
std::vector<char> contact_zone(const Model& model, const ContactSystem& contact, const ContactZoneOptions& o);

}  // namespace peristat
