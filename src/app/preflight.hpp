// Checks of a scene before it is discretised (issue 15, "Refuse what cannot fit";
// docs/guide/cli.md): the size of a family, a horizon longer than a body, and the memory
// the model and its tangent will take, estimated from the scene alone so that a run that
// cannot fit is refused (exit 2, with the numbers) before anything is allocated.
#pragma once

#include <string>
#include <vector>

#include "app/run_plan.hpp"
#include "scene/scene.hpp"

namespace peristat {

/// The estimate, from the scene alone (no lattice is built).
struct SizeEstimate {
  double particles = 0.0;          ///< real particles: the bodies' areas / dx^2
  double fictitious = 0.0;         ///< layers along the edges that carry conditions
  double family = 0.0;             ///< bonds per interior family (the stencil's; pi (m + 1/2)^2 for m > 64)
  double nonzeros = 0.0;           ///< of the tangent: 4 per pair of particles within 2 horizons
  double memory_bytes = 0.0;       ///< model, problem state and tangent (no factorisation), per rank
  double factor_nonzeros = 0.0;    ///< of the Cholesky factor the linear solver makes (0: none)
  double factor_bytes = 0.0;       ///< the factor and the copy of the matrix the factorisation takes
  std::string factor_of;           ///< what is factorised: "the tangent", "the bond preconditioner" or ""
  double available_bytes = 0.0;    ///< MemAvailable of /proc/meminfo over the ranks sharing it; 0 when unknown
  int sharing_ranks = 1;           ///< MPI ranks on this machine, each holding the whole model and its rows
};

/// Bytes per tangent nonzero of the model, problem state and tangent together, per nonzero of
/// the estimate, measured with `check --set solver.linear=cg` on the tension plate (16.9), the
/// paper's cases 4.1 (18.8), 4.3 (18.2) and 4.4 (21.4) and the LEFM inclined crack (21.1;
/// 2026-12-04).
inline constexpr double kBytesPerNonzero = 19.0;
/// The same without the tangent and its pattern (solver.linear: matrix_free), per nonzero of the
/// estimate: 3.40-3.43 B measured with `check` on the tension plate (100 x 100 and 1000 x 1000)
/// and cases 4.1 (3.59) and 4.3 (3.68; 2026-12-04). The largest, rounded up, so that a refusal
/// errs on the safe side ...
inline constexpr double kMatrixFreeBytesPerNonzero = 3.7;
/// ... and with a failure criterion 2.6 B more (the bonds' displacements and the failure
/// state: case 4.4, 6.19 B, 6.20 B at dx = 0.01 m; the LEFM inclined crack, 6.16 B).
inline constexpr double kMatrixFreeFailureBytesPerNonzero = 2.6;
/// ... and with the action's factors in single precision (solver.krylov.factors float) 1.3 B
/// less: 16 of their 32 bytes per directed bond (the 1000 x 1000 plate, `check`, 2026-12-04:
/// 1,125 against 1,838 MB, 2.08 against 3.40 B per estimated nonzero).
inline constexpr double kMatrixFreeFloatFactorsSaving = 1.3;
/// Matrix-free bytes per tangent nonzero of a scene; a float copy beside double factors
/// (solver.krylov.factors mixed) adds what float factors save.
inline double matrix_free_bytes_per_nonzero(bool failure, bool float_factors = false,
                                            bool float_copy = false) {
  return kMatrixFreeBytesPerNonzero + (failure ? kMatrixFreeFailureBytesPerNonzero : 0.0) -
         (float_factors ? kMatrixFreeFloatFactorsSaving : 0.0) +
         (float_copy ? kMatrixFreeFloatFactorsSaving : 0.0);
}
/// The Cholesky factor's nonzeros per nonzero of the matrix factorised, by CHOLMOD's default
/// ordering on square plates of N particles (m = 3; peristat_bench factor, 2026-11-25): the
/// tangent 1.97, 3.08, 4.34 at N = 2,500, 10,000, 40,000, i.e. 0.59 log2 N - 4.7; the bond
/// preconditioner (0.14 of the tangent's nonzeros) 3.5, 5.1, 5.6, i.e. 0.51 log2 N - 2.0.
double factor_fill(double particles, bool bond_preconditioner);
/// Bytes per factor nonzero (values and supernodal indices) and per nonzero of the matrix
/// CHOLMOD copies: with kBytesPerNonzero they give the measured peak memory of the factorisation
/// within 12% (2,500 to 40,000 particles; 2.06 GB measured, 1.98 GB estimated at 40,000).
inline constexpr double kBytesPerFactorNonzero = 10.0;
/// Bytes per bond-matrix nonzero of solver.krylov.preconditioner bond_amg: the matrix, its
/// copy in Tpetra and MueLu's hierarchy, measured at 1000 x 1000 (2.4 GB beyond the model for
/// 3.6e7 nonzeros at radius 1.42, 2026-11-25).
inline constexpr double kBytesPerAmgNonzero = 65.0;
/// The threaded V-cycle also keeps the finest matrix in 2 x 2 blocks (solvers/trilinos/threaded_cycle.hpp,
/// Blocks: 4 float values and one index per block of four nonzeros, written straight as floats).
inline constexpr double kBytesPerBlockedNonzero = 5.0;
inline constexpr double kBytesPerCopiedNonzero = 12.0;
/// Largest family accepted (bonds of an interior particle): horizon_factor up to about 24.
inline constexpr double kMaxFamily = 2000.0;

/// The model's part of the estimate: particles, fictitious, family, nonzeros, and the memory
/// with an assembled tangent (no solver priced, no machine read).
SizeEstimate estimate_model(const Scene& scene);
/// The whole estimate of a run with `plan`: the model, what its solver adds (the tangent or
/// not, the factorisation or preconditioner), per rank, and the memory available.
SizeEstimate estimate_size(const Scene& scene, const RunPlan& plan);
/// The same for the run the scene would make in one process (make_run_plan(scene, 1)).
SizeEstimate estimate_size(const Scene& scene);

/// The unknowns `solver.linear: auto` decides by before discretising: two per real particle
/// (the fictitious layers' components are prescribed).
inline double estimated_unknowns(const SizeEstimate& e) { return 2.0 * e.particles; }

/// Throws InputError (exit 2) when the scene cannot be run: a family over kMaxFamily bonds,
/// a horizon longer than a body's longest side, or an estimated memory over what the machine
/// has available. Returns warnings to print (horizon_factor below 2).
std::vector<std::string> preflight(const Scene& scene, const RunPlan& plan, const SizeEstimate& estimate);

}  // namespace peristat
