// How this process's vectors map onto the whole model's, for what rank 0 writes (results,
// checkpoints): the identity where the process holds the whole model, a gather by global id
// where it holds a rank's part (ModelPart; docs/guide/distributed.md "The partitioned model").
// The files of a run on the parts are then those of a serial run, particle for particle.
#pragma once

#include <cstdint>
#include <vector>

#include "core/types.hpp"
#include "discretisation/model_part.hpp"
#include "io/results.hpp"
#include "parallel/ranks.hpp"
#include "scene/scene.hpp"

namespace peristat {

class WholeView {
 public:
  /// The whole model (`part` null: every vector is already whole), or this rank's part of it.
  WholeView(const Model& model, const ModelPart* part, const Ranks& ranks);

  /// Whether the methods below communicate (a part): every rank must then call them alike.
  bool gathers() const { return m_part != nullptr; }
  /// The whole model's particle count.
  std::size_t particles() const;

  /// The whole model's particle table, on rank 0 (collective on a part; empty elsewhere).
  ParticleTable particle_table(const Scene& scene) const;
  /// `width` values per particle of this process's model (interleaved, e.g. the 2N displacement)
  /// as the whole model's, on rank 0; `whole` is left empty on the other ranks. Collective on a part.
  void particle_values(const VectorXd& mine, int width, VectorXd& whole) const;
  /// The state over the whole model's unknowns from this process's (its own entries: the
  /// first ones of a part), on rank 0. Collective on a part.
  std::vector<double> unknowns(const VectorXd& x) const;
  /// This process's state from the whole model's (a checkpoint's, read on every rank): a part
  /// takes its own unknowns and its ghosts'.
  VectorXd unknowns_from(const std::vector<double>& whole) const;

 private:
  const Model& m_model;
  const ModelPart* m_part = nullptr;
  const Ranks& m_ranks;
  bool m_root = true;
  std::vector<Index> m_given;                  ///< the part's particles whose rows this rank gives
  std::vector<std::int64_t> m_given_ids;       ///< their global ids
  std::vector<std::int64_t> m_owned_unknowns;  ///< the global ids of the part's own unknowns
  mutable std::vector<double> m_buffer;
};

}  // namespace peristat
