// The damage of the particles at the last accepted state, and the check that no converged
// state heals a broken bond (damage never decreases; docs/theory/failure.md).
#pragma once

#include <cstddef>
#include <string>

#include "core/types.hpp"
#include "parallel/ranks.hpp"
#include "discretisation/model.hpp"
#include "materials/bond_failure.hpp"

namespace peristat {

struct ProblemOptions;

class DamageHistory {
 public:
  /// Without failure (null): no damage, every check passes. The accepted damage starts at
  /// zero. `options` (the problem's, which must outlive this) gives the rows and the gather
  /// of a distributed run.
  DamageHistory(const Model& model, const BondFailure* failure, const ProblemOptions& options, const Ranks& ranks);
  DamageHistory(const DamageHistory&) = delete;
  DamageHistory& operator=(const DamageHistory&) = delete;

  /// Why the damage at the failure's current bonds is below the accepted one at some particle
  /// (a healed bond), or "". On a part: collective.
  std::string check();
  /// The damage at the failure's current bonds becomes the accepted one (collective where
  /// BondFailure::damage() is).
  void commit();
  /// Per particle, at the last accepted state (empty without failure).
  const VectorXd& accepted() const { return m_damage_accepted; }
  std::size_t memory_bytes() const {
    return static_cast<std::size_t>(m_damage_accepted.size() + m_damage_now.size()) * sizeof(double);
  }

 private:
  const Model& m_model;
  const BondFailure* m_failure;
  const ProblemOptions& m_options;
  const Ranks& m_ranks;
  VectorXd m_damage_accepted, m_damage_now;  ///< per particle
};

}  // namespace peristat
