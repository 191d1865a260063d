// How this process's vectors map onto the whole model's, for what rank 0 writes (results,
// checkpoints): a gather by global id from the parts (ModelPart; docs/guide/distributed.md
// "The partitioned model"); in one process, whose part is the whole model, the identity's copy.
// The files of a run on P ranks are then those of one process, particle for particle.
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
  /// This process's part of the model (one process: the whole model as one part).
  WholeView(const ModelPart& part, const Ranks& ranks);

  /// The whole model's particle count.
  std::size_t particles() const { return static_cast<std::size_t>(m_part.n_particles_whole); }

  // Collective: every rank calls them alike.
  /// The whole model's particle table, on rank 0 (empty elsewhere).
  ParticleTable particle_table(const Scene& scene) const;
  /// `width` values per particle of this process's part (interleaved, e.g. the 2N displacement)
  /// as the whole model's, on rank 0; `whole` is left empty on the other ranks.
  void particle_values(const VectorXd& mine, int width, VectorXd& whole) const;
  /// The state over the whole model's unknowns from this process's (its own entries: the
  /// first ones of a part), on rank 0.
  std::vector<double> unknowns(const VectorXd& x) const;
  /// This process's state from the whole model's (a checkpoint's, read on every rank): a part
  /// takes its own unknowns and its ghosts'.
  VectorXd unknowns_from(const std::vector<double>& whole) const;

 private:
  const ModelPart& m_part;
  const Ranks& m_ranks;
  bool m_root = true;
  std::vector<Index> m_given;                  ///< the part's particles whose rows this rank gives
  std::vector<std::int64_t> m_given_ids;       ///< their global ids
  std::vector<std::int64_t> m_owned_unknowns;  ///< the global ids of the part's own unknowns
  mutable std::vector<double> m_buffer;
};

}  // namespace peristat
