// Zoltan2's recursive coordinate bisection, for solver.belos.partition: rcb
// (docs/guide/distributed.md). Behind the Trilinos seam like the rest of solvers/trilinos:
// plain vectors in, plain vectors out.
#pragma once

#include <vector>

namespace peristat {

/// The part (0 .. parts - 1) of each point (x[k], y[k]): recursive coordinate bisection into
/// `parts` parts of equal count (to one point). Computed in this process alone (a serial
/// communicator), so that every rank, given the same points, gets the same answer.
/// Throws std::runtime_error when Zoltan2 fails.
std::vector<int> rcb_parts(const std::vector<double>& x, const std::vector<double>& y, int parts);

}  // namespace peristat
