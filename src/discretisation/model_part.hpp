// A rank's part of a model: the first stage of the partitioned model (docs/guide/distributed.md,
// "The partitioned model"). The part is a Model of its own, numbered owned particles first,
// so that the kernels, the constraints and the problem run on it unchanged; this header adds
// only the map back to the whole model. Nothing about MPI here.
#pragma once

#include <cstdint>
#include <vector>

#include "discretisation/lattice_partition.hpp"
#include "discretisation/model.hpp"

namespace peristat {

struct ModelPart {
  /// The part's particles: first those the rank owns, then the others it reads or whose
  /// families it computes, each group in the whole model's order. Its unknowns follow the
  /// same order, so the owned unknowns come first. Bonds are held for the families `held`
  /// named (Model::family_held); a held family's bond to a family not held has no reverse.
  /// The whole model's counts (n_bonds_whole, n_cut_bonds) are kept. `whole_start` gives, per
  /// particle of the part, the whole model's index of its family's first bond (the last entry
  /// n_bonds_whole): not increasing, as the part's order is not the whole's.
  Model model;
  Index n_owned = 0;                         ///< particles of `model` the rank owns (the first ones)
  Index n_owned_unknowns = 0;                ///< their unknowns (the first ones)
  std::vector<std::int64_t> global_id;       ///< per particle of `model`: its index in the whole model
  std::vector<int> owner;                    ///< per particle of `model`: the rank owning its rows (-1: none)
  std::vector<std::int64_t> global_unknown;  ///< per unknown of `model`: its index among the whole's
  std::int64_t n_particles_whole = 0;
  std::int64_t n_unknowns_whole = 0;

  /// Bytes held: the model's and the maps'.
  std::size_t memory_bytes() const;
};

/// The part of `whole` that rank `rank` needs when `owner` (per particle of `whole`: the rank
/// owning its rows, -1 for a particle without unknowns) splits the rows, and it computes the
/// families `held` names (per particle of `whole`; e.g. app/setup.hpp's families_to_hold(),
/// which holds every particle without an owner, so every rank computes those alike). The part
/// keeps the held particles, every neighbour of theirs, the `extra` particles (global ids: e.g.
/// contact partners that slid towards the part, PartsOutgrown) and the source of every mirror
/// ghost it keeps. `whole` must hold every family `held` names. Throws std::logic_error
/// otherwise, or when a particle `rank` owns is not held.
ModelPart extract_part(const Model& whole, const std::vector<int>& owner, int rank,
                       const std::vector<char>& held, const std::vector<std::int64_t>& extra = {});

/// Rank `rank`'s part of the scene's model, built from the census alone (no process holds
/// particles it does not keep): the particles `partition` gives the rank (LatticePartition::
/// owner()), the families of every particle within `rings` stencils of them, every neighbour
/// of those, the `extra` particles (global ids: contact partners that slid towards the part,
/// PartsOutgrown) and the source of every mirror ghost kept. The part extract_part() cuts
/// from the whole model with the same owners, particle for particle. `census` must have
/// counted the families (take_census()).
ModelPart build_part(const ModelDescription& scene, const LatticeCensus& census, const LatticePartition& partition,
                     int rank, int rings, const std::vector<std::int64_t>& extra = {});

/// One process's model as the one part of one rank: `whole` itself (moved, not copied), every
/// particle and unknown its own, numbered by itself (identity global ids), every family held.
/// The part extract_part() cuts for one rank, without the copy (a one-process run and a rank's
/// run take the same paths: docs/guide/distributed.md, "The partitioned model").
ModelPart whole_as_part(Model&& whole);

}  // namespace peristat
