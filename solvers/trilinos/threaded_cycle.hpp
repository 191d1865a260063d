// The V-cycle of a MueLu hierarchy applied by this program's OpenMP threads instead of by
// MueLu (docs/theory/newton.md, "Bond preconditioner"). Debian's Trilinos has Kokkos' Serial
// back end only, so MueLu's own apply runs on one core while the tangent's action around it
// uses all of them: on case 4.1 (2 threads) the V-cycle was 44% of the main thread's time. MueLu
// still builds the hierarchy (aggregates, prolongators, Galerkin products, the smoothers'
// eigenvalue estimates); this class reads it and repeats MueLu's cycle (Hierarchy::Iterate)
// with Ifpack2's Chebyshev and Jacobi arithmetic (Ifpack2::Details::Chebyshev::
// ifpackApplyImpl, Ifpack2::Relaxation) on the same matrices, held, not copied (except the
// finest one's 2 x 2 blocks: Blocks, after which the cycle holds its CSR graph only). A hierarchy it
// does not recognise is reported, and MueLu applies the cycle itself. Compiled as C++17 with
// the rest of the Trilinos adapter.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <MueLu_Hierarchy.hpp>
#include <Tpetra_CrsMatrix.hpp>

namespace peristat {

class ThreadedCycle {
 public:
  using crs_t = Tpetra::CrsMatrix<double>;
  using LO = crs_t::local_ordinal_type;
  using GO = crs_t::global_ordinal_type;
  using NT = crs_t::node_type;
  using hierarchy_t = MueLu::Hierarchy<double, LO, GO, NT>;

  /// How the finest level's matrix is read by the smoothers and the residual.
  enum class Finest {
    csr,           ///< MueLu's CSR matrix itself (no copy)
    blocks,        ///< a copy in 2 x 2 blocks of doubles: MueLu's arithmetic, the same bits
    float_blocks,  ///< a copy in 2 x 2 blocks of floats (Blocks): a preconditioner of A_f, A rounded
  };

  /// The cycle of `h` (one process, no rebalancing), or null with the reason in `why_not`.
  /// `finest`: blocks of either kind need two rows per particle (odd rows: csr); float_blocks
  /// holds doubles instead where a non-zero entry is beyond a float's range or subnormal as one.
  /// `pre_degree` > 0: the Chebyshev pre-smoothers of a higher degree are applied with this
  /// degree (their eigenvalue estimates unchanged), a cycle lighter before than after and no
  /// longer symmetric; 0: MueLu's smoothing.
  static std::unique_ptr<ThreadedCycle> from(hierarchy_t& h, std::string& why_not, Finest finest,
                                             int pre_degree = 0);

  /// x = M b: one V-cycle from a zero initial guess, as MueLu's apply of the hierarchy as a
  /// preconditioner. b and x hold the finest level's rows.
  void apply(const double* b, double* x);

  /// The bytes of matrix data one apply() reads: each level's matrix once per sweep (a
  /// Chebyshev smoother of degree d sweeps d times, once fewer from a zero guess; the residual
  /// once) and its prolongator twice (P^T r, P x_c). The vectors are not counted. For the
  /// roofline of docs/performance.md (peristat_bench cycle).
  double matrix_bytes_per_apply() const;

  /// A matrix with two rows per particle in 2 x 2 blocks (block row p: rows 2p and 2p + 1;
  /// an entry absent from one of the two rows is stored as zero). The residual and smoother
  /// kernels form two rows at a time from it, each row's subtractions in the CSR row's order
  /// (with doubles, the same bits): a block column loads x's pair once and its column index
  /// once for two rows. Case 4.1: the V-cycle 1.07 -> 0.79 s over 318 cycles (medians of 4
  /// runs), for a copy of the finest matrix (about 9 bytes per nonzero).
  /// The values rounded to floats (the arithmetic stays double) halve the bytes the finest
  /// level's five sweeps read per cycle: the cycle is then a fixed, symmetric operator built
  /// on A_f = fl(A) (relative change 6e-8 per entry) instead of A, which the Krylov method
  /// never sees (it applies the exact tangent). About 5 bytes per nonzero.
  struct Blocks {
    std::vector<std::size_t> start;  ///< per block row, into col (and 4 x into values or rounded)
    std::vector<LO> col;             ///< block column
    std::vector<double> values;      ///< per block, column by column: a00 a10 a01 a11 (or empty)
    std::vector<float> rounded;      ///< the same rounded to floats, when values is empty
    bool empty() const { return start.empty(); }
  };

 private:
  using local_t = crs_t::local_matrix_host_type;

  /// A smoother's arithmetic: Chebyshev (Ifpack2's "ifpack" variant) or damped Jacobi.
  struct Smoother {
    enum class Kind { none, chebyshev, jacobi } kind = Kind::none;
    int degree = 1;          ///< Chebyshev degree, or Jacobi sweeps
    double lambda_max = 0;   ///< Chebyshev: Ifpack2's estimate of the largest eigenvalue of D^-1 A
    double ratio = 0;        ///< Chebyshev: lambda_max / lambda_min
    double boost = 1.1;      ///< Chebyshev: the boost of lambda_max
    double damping = 1.0;    ///< Jacobi
    /// Chebyshev: a diagonal entry below it in magnitude gets it as its inverse, as in Ifpack2
    /// (default: machine epsilon)
    double min_diagonal = 0.0;
  };

  struct Level {
    local_t A;                   ///< this level's matrix
    Blocks blocks;               ///< the finest level's A in 2 x 2 blocks (empty on the others)
    local_t P;                   ///< prolongation from the next level (not on the coarsest)
    std::vector<double> d_inv;   ///< 1 / diag(A)
    Smoother pre, post;
    std::vector<double> b, x;  ///< right-hand side and iterate (the coarser levels'; the finest's are the caller's)
    /// The smoother's W, and the residual between the smoothers: never live at once, one
    /// buffer (16 MB less at a million particles, where the memory goal is tight)
    std::vector<double> work;
    std::vector<double> chunks;      ///< restriction: kChunks partial sums of the next level's rows
  };

  /// Restriction P^T r sums over fixed row ranges, one buffer each, then adds the buffers in
  /// order: the same bits on any number of threads.
  static constexpr int kChunks = 4;

  static bool read_smoother(const Teuchos::RCP<MueLu::SmootherBase<double, LO, GO, NT>>& s, Smoother& out,
                            std::string& why_not);
  /// Level i's smoothers (MueLu level `L`) into `level`, and its D^-1 (level.d_inv, as Ifpack2
  /// computes it); false with the reason in `why_not` when the cycle cannot repeat them.
  static bool read_smoothing(MueLu::Level& L, int i, Level& level, std::string& why_not);
  void cycle(std::size_t l, const double* b, double* x);
  void smooth(Level& level, const Smoother& s, const double* b, double* x, bool zero_guess);

  std::vector<Level> m_levels;
};

}  // namespace peristat
