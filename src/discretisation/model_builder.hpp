// Builds a Model from the lattice census: the whole model (discretise()) or a rank's part
// (build_part()), through the same steps. The particles a model keeps are numbered as the
// whole model's in one pass over the census; only they are ever stored.
#pragma once

#include <cstdint>
#include <vector>

#include "core/description.hpp"
#include "discretisation/census.hpp"
#include "discretisation/model.hpp"

namespace peristat {

/// A lattice point a model keeps, with its numbers in the whole model.
struct KeptPoint {
  int i = 0, j = 0;
  std::int64_t id = 0;             ///< the particle's number in the whole model
  std::int64_t first_unknown = 0;  ///< the whole model's number of its first free component
  std::int64_t first_bond = 0;     ///< the whole model's index of its family's first bond (families counted)
  bool owned = true, held = true;  ///< a part's: its rows are this rank's; its family is built
};

/// The points `keep(i, j, id)` accepts (each an existing particle's), numbered; in lattice order.
template <class Keep>
std::vector<KeptPoint> number_points(const LatticeCensus& census, Keep keep) {
  const std::size_t groups = census.group_body.size();
  std::vector<std::int64_t> id(groups, 0), unknown(groups, 0), bond(groups, 0);
  for (std::size_t g = 1; g < groups; ++g) {  // each group's first numbers
    id[g] = id[g - 1] + census.group_particles[g - 1];
    unknown[g] = unknown[g - 1] + census.group_free[g - 1];
    bond[g] = bond[g - 1] + census.group_bonds[g - 1];
  }
  std::vector<KeptPoint> kept;
  for (int i = census.i0; i < census.i0 + census.ni; ++i)
    for (int j = census.j0; j < census.j0 + census.nj; ++j) {
      const CensusPoint& p = census.point[census.linear(i, j)];
      if (!p.exists()) continue;
      if (keep(i, j, id[p.group])) kept.push_back({i, j, id[p.group], unknown[p.group], bond[p.group], true, true});
      ++id[p.group];
      unknown[p.group] += p.free_components();
      bond[p.group] += p.family;
    }
  return kept;
}

/// The model of the `kept` points, in that order: its particles, their constraints (numbered
/// in that order) and the families of the held ones. `whole`: every particle kept and held
/// (Model::family_held and whole_start empty); otherwise the census must have counted the
/// families, and `global_unknown` receives each unknown's number in the whole model.
Model model_of(const ModelDescription& scene, const LatticeCensus& census, const std::vector<KeptPoint>& kept,
               bool whole, std::vector<std::int64_t>* global_unknown = nullptr);

}  // namespace peristat
