// The assembler's bookkeeping that is neither physics nor assembly: which particles a rank of
// a distributed run computes (RankShare), and where the wall time goes (Timings).
#pragma once

#include <cstddef>
#include <vector>

#include "assembly/pattern.hpp"
#include "contact/contact.hpp"
#include "core/types.hpp"
#include "discretisation/model.hpp"

namespace peristat {

/// Wall time spent in the contact pairs [s]: building the candidates, and evaluating the
/// pairs (summed over every evaluation so far).
struct Timings {
  double contact_setup = 0.0;
  double contact = 0.0;
};

/// What this process computes of its model (every family and force of a whole model; a
/// rank's part: the families and forces its own rows read): per particle, whether it computes
/// its force and its family, and the particles and unknowns whose rows other ranks own (zero
/// in the own-rows residual and in the action). Built once, at the problem's construction.
class RankShare {
 public:
  RankShare() = default;
  /// The forces this rank computes: its particles' and those of the particles without a row
  /// (fictitious layers, mirror ghosts: no unknown reads them, but the force scale counts their
  /// reactions). Their forces read the families of their neighbours.
  RankShare(const Model& model, const OwnedRows& rows);

  bool built() const { return !m_force_needed.empty(); }
  bool force_needed(Index q) const { return m_force_needed[static_cast<std::size_t>(q)] != 0; }
  bool family_needed(Index i) const { return m_family_needed[static_cast<std::size_t>(i)] != 0; }
  /// The unknowns of other ranks, ascending (none in one process).
  const std::vector<Index>& other_unknowns() const { return m_other_unknowns; }
  /// The particles whose rows other ranks own, ascending (none in one process).
  const std::vector<Index>& other_particles() const { return m_other_particles; }
  std::size_t memory_bytes() const;

 private:
  std::vector<char> m_force_needed, m_family_needed;  ///< per particle
  std::vector<Index> m_other_unknowns, m_other_particles;
};

/// The free unknowns (ascending) of the particles `read` marks, with the sources of the mirror
/// ghosts among them (a ghost's displacement is its source's image).
std::vector<Index> read_unknowns(const Constraints& cons, std::vector<char>& read);

}  // namespace peristat
