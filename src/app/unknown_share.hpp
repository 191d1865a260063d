// How distributed ADR shares the unknowns among the ranks (solvers/distribution.hpp): on a
// rank's part of the model, by the problem's own ghost exchange; on the whole model with the
// rows split, by an exchange of every owned entry and one of the entries a rank's rows read.
#pragma once

#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"
#include "solvers/distribution.hpp"

namespace peristat {

/// A rank's part: its own unknowns first; the ghost tail comes from the problem's exchange.
UnknownShare part_unknown_share(QuasiStaticProblem& problem, const ModelPart& part);
/// The whole model on the ranks (the problem's owned rows); one process: nothing shared.
UnknownShare unknown_share(QuasiStaticProblem& problem);

}  // namespace peristat
