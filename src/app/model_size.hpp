// The model size figures printed by `check` and `run` and stored in summary.json. The memory
// estimate asks each object for the bytes it holds.
#pragma once

#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"

namespace peristat {

struct ModelSize {
  Index particles = 0, fictitious = 0, cut_bonds = 0, unknowns = 0, prescribed = 0;
  long long bonds = 0;  ///< the whole model's, which a distributed run may hold in parts (more than 2^31)
  long long nonzeros = 0;
  double memory_bytes = 0.0;  ///< model + problem state + one tangent (factorisation excluded)
  SurfaceCorrectionMethod correction = SurfaceCorrectionMethod::none;
  SurfaceCorrectionStats correction_stats;  ///< of the factors computed when the problem was built
  /// Under mpirun (each rank its part, some families only): the most directed bonds one rank holds (of 2 x bonds).
  bool bonds_partitioned = false;
  long long largest_rank_bonds = 0;
  /// Under mpirun (every rank its part): the most particles one rank's part holds.
  bool part = false;
  int ranks = 1;  ///< the ranks of the run
  long long largest_rank_particles = 0;
};

/// The counts are the whole model's: with `part` (this rank's part of it, collective), summed
/// over the ranks' own particles; the memory is this process's.
ModelSize measure(const Model& model, const QuasiStaticProblem& problem, const ModelPart* part = nullptr);
void print_size(const ModelSize& size);

}  // namespace peristat
