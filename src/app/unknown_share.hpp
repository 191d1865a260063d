// How distributed ADR shares the unknowns among the ranks (solvers/distribution.hpp): on a
// rank's part of the model, by the problem's own ghost exchange.
#pragma once

#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"
#include "solvers/distribution.hpp"

namespace peristat {

/// A rank's part: its own unknowns first; the ghost tail comes from the problem's exchange.
UnknownShare part_unknown_share(QuasiStaticProblem& problem, const ModelPart& part);

}  // namespace peristat
