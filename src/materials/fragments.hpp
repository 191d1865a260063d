// Pieces cut loose by broken bonds (issue 15, docs/theory/failure.md "Fragments"): the
// connected components of the intact bonds, and which of them hold no prescribed component.
#pragma once

#include <span>
#include <vector>

#include "core/partition.hpp"
#include "discretisation/model.hpp"

namespace peristat {

/// A rank's part of the bond graph when its model holds some families only (partitioned
/// bonds): the families whose pairs (i, j > i) it joins, each pair on exactly one rank, and
/// the gather that combines the ranks' pieces.
struct GraphParts {
  std::span<const char> families;
  GatherOverRanks gather;
};

/// Marks (1) every particle whose component of the bond graph, over the bonds with a nonzero
/// `intact` weight, holds no prescribed displacement component. `unsupported` gets N entries;
/// `component` (N) the component of each particle, as the index of one of its particles.
/// With `parts` (collective): each rank joins its families' pairs, and the components are
/// those of the union of every rank's pieces, the same on every rank (the component's
/// representative may differ from one process's).
void find_unsupported(const Model& model, std::span<const double> intact, std::vector<char>& unsupported,
                      std::vector<Index>& component, const GraphParts* parts = nullptr);

}  // namespace peristat
