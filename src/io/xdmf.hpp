// Private to src/io: the XDMF description that lets ParaView open a results file.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace peristat::io {

/// What the XDMF needs to know about one written step.
struct XdmfStep {
  int index = 0;      ///< K of /steps/%06d
  double time = 0.0;  ///< load factor, shown as time in ParaView
  bool has_damage = false;
  bool has_contact_force = false;
  bool has_contact_state = false;
  bool has_held = false;
};

/// Xdmf 2 document: a temporal collection with one Polyvertex grid per step, geometry
/// XY from /particles/position of `h5_file_name` (a name relative to the XDMF file),
/// Time = load factor, N x 2 datasets as vector attributes and per-particle scalars.
std::string xdmf_document(const std::string& h5_file_name, std::size_t n_particles,
                          const std::vector<XdmfStep>& steps);

}  // namespace peristat::io
