// Pieces cut loose by broken bonds (issue 15, docs/theory/failure.md "Fragments"): the
// connected components of the intact bonds, and which of them hold no prescribed component.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "discretisation/model.hpp"
#include "parallel/exchange.hpp"
#include "parallel/ranks.hpp"

namespace peristat {

/// A rank's part of the bond graph on its part of the model: the families whose pairs
/// (i, j > i) it joins, each pair on exactly one rank, and the ranks that combine their pieces.
struct GraphParts {
  const Ranks& ranks;
  std::span<const char> families;
  /// Per particle of the part (discretisation/model_part.hpp): its index in the whole model
  /// and its owner (-1: none, every rank holds it alike; rank 0 joins its family), and the
  /// exchange of one value per particle from each owner into the ranks that read it.
  std::span<const std::int64_t> global_id;
  std::span<const int> owner;
  ValueExchange* share = nullptr;
};

/// Marks (1) every particle whose component of the bond graph, over the bonds with a nonzero
/// `intact` weight, holds no prescribed displacement component. `unsupported` gets N entries;
/// `component` (N) the component of each particle, as the index of one of its particles.
/// With `parts` (collective, on a rank's part): each rank joins its families' pairs, and the
/// components are those of the union of every rank's pieces, the same on every rank;
/// `component` names each particle's component by the global id of one of its particles, the
/// same on every rank, and what is gathered is the links between the ranks' pieces, not every
/// particle's.
void find_unsupported(const Model& model, std::span<const double> intact, std::vector<char>& unsupported,
                      std::vector<Index>& component, const GraphParts* parts = nullptr);

}  // namespace peristat
