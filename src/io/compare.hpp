// Difference measures between two results of the same discretisation, for
// `peristat compare A.h5 B.h5` (B is the reference). Only non-fictitious particles count.
#pragma once

#include <string>
#include <vector>

#include "core/types.hpp"
#include "io/results.hpp"

namespace peristat {

/// Displacement difference over a set of particles, du_i = uA_i - uB_i (2-vectors):
///   relative_l2   ||du|| / ||uB||   (norms over the stacked 2-vectors of the set)
///   max_abs       max_i |du_i| [m]  (Euclidean per particle)
///   max_relative  max_abs / max_i |uB_i|
/// When uB is zero on the whole set, both ratios fall back to the absolute values
/// (||du|| and max_abs, in metres) and `absolute` is true.
struct DifferenceMeasures {
  Index particles = 0;     ///< particles in the set
  double norm_diff = 0.0;  ///< ||du|| [m]
  double norm_b = 0.0;     ///< ||uB|| [m]
  double max_b = 0.0;      ///< max_i |uB_i| [m]
  double relative_l2 = 0.0;
  double max_abs = 0.0;
  double max_relative = 0.0;
  bool absolute = false;  ///< uB == 0 on the set: the two ratios are absolute values [m]
};

/// The measures of one body (bodies without a real particle are left out).
struct BodyDifference {
  int index = 0;
  std::string name;  ///< from the /particles attribute body_names, else the index ("0", "1", ...)
  DifferenceMeasures measures;
};

struct Comparison {
  DifferenceMeasures all;
  std::vector<BodyDifference> bodies;  ///< ascending body index
  /// Real particles left out because either result holds them as fragments: a fragment is
  /// held wherever it was cut loose, a position the equations do not determine
  /// (docs/theory/failure.md, "Fragments").
  Index held_left_out = 0;
};

/// Empty when `a` and `b` hold the same particles: same count, fictitious flags and body
/// indices, and reference positions equal to 1e-9 times the largest |position| of either
/// table (1e-12 m when every position is 0). Otherwise one phrase saying what differs,
/// naming the tables by `name_a` and `name_b`, e.g. "a.h5 has 676 particles, b.h5 has 2601".
std::string particle_mismatch(const ParticleTable& a, const std::string& name_a, const ParticleTable& b,
                              const std::string& name_b);

/// Throws InputError naming both files when particle_mismatch finds a difference.
void require_same_particles(const ResultsReader& a, const std::string& name_a, const ResultsReader& b,
                            const std::string& name_b);

/// Measures of uA - uB (2N interleaved each) over the non-fictitious particles of
/// `particles`, overall and per body, leaving out those with a nonzero entry of `left_out`
/// (N, or empty: none). Throws InputError unless both have size 2N.
Comparison compare_displacements(const ParticleTable& particles, const VectorXd& u_a, const VectorXd& u_b,
                                 const VectorXd& left_out = VectorXd());

/// Reads step `step_a` of `a` and `step_b` of `b` and compares them (B is the reference),
/// leaving out the particles either step holds as fragments (ResultsReader::held); throws
/// InputError when that leaves no real particle (a verdict over nothing would pass any --tol).
/// Throws InputError as require_same_particles does, and naming the file when a step is absent.
Comparison compare_results(const ResultsReader& a, const std::string& name_a, int step_a,
                           const ResultsReader& b, const std::string& name_b, int step_b);

}  // namespace peristat
