// Pieces cut loose by broken bonds (issue 15, docs/theory/failure.md "Fragments"): the
// connected components of the intact bonds, and which of them hold no prescribed component.
#pragma once

#include <span>
#include <vector>

#include "discretisation/model.hpp"

namespace peristat {

/// Marks (1) every particle whose component of the bond graph, over the bonds with a nonzero
/// `intact` weight, holds no prescribed displacement component. `unsupported` gets N entries;
/// `component` (N) the component of each particle, as the index of one of its particles.
void find_unsupported(const Model& model, std::span<const double> intact, std::vector<char>& unsupported,
                      std::vector<Index>& component);

}  // namespace peristat
