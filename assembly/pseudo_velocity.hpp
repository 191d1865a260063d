// ADR's own seam: a problem whose residual also depends on the pseudo-velocity of the
// unknowns (the paper's velocity-sign friction, eq 13; docs/theory/adr.md). Only ADR has a
// velocity, so only AdrSolver takes this interface; Problem knows nothing of it.
#pragma once

#include "core/types.hpp"

namespace peristat {

class PseudoVelocityInput {
 public:
  virtual ~PseudoVelocityInput() = default;
  /// The pseudo-velocity of the unknowns that the next evaluate() uses.
  virtual void set_velocity(const VectorXd& v) = 0;
};

}  // namespace peristat
