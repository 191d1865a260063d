// solver.krylov.preconditioner: bond_amg. One V-cycle of MueLu's smoothed aggregation of the
// bond matrix, as the preconditioner of factor-preconditioned Krylov (solvers/linear/
// factor_krylov.hpp), applied by this program's threads (solvers/trilinos/threaded_cycle.hpp).
// Part of the Trilinos adapter (C++17).
#include <exception>
#include <memory>
#include <string>

#include <MueLu_CreateTpetraPreconditioner.hpp>
#include <Teuchos_DefaultMpiComm.hpp>

#include "solvers/trilinos/belos_solver.hpp"
#include "solvers/trilinos/tpetra_start.hpp"
#include "solvers/trilinos/threaded_cycle.hpp"
#include "solvers/trilinos/tpetra_adapter.hpp"

namespace peristat {

namespace {

using namespace tpetra;

/// One V-cycle of MueLu's smoothed aggregation on a matrix P, as the preconditioner "solve"
/// of factor-preconditioned Krylov (solver.krylov.preconditioner: bond_amg): the bond matrix
/// approximated instead of factorised. In this process only (a serial communicator), the
/// unknowns grouped by particle with the rigid-body modes as near-null space. A fixed linear
/// operator; for CG (may_be_unsymmetric false) symmetric positive definite for a symmetric
/// positive definite P (Chebyshev smoothing, the same before and after, and a relaxed coarsest
/// level); for GMRES, on the threads, lighter before than after, not symmetric (symmetric()).
class MueLuCycle final : public Preconditioner {
 public:
  MueLuCycle(const LinearSetup& setup, CycleApply apply)
      : m_layout(setup.layout), m_apply(apply), m_gmres(setup.may_be_unsymmetric) {
    parallel::ensure_started();
    // This process's own communicator: under mpirun every rank runs the same Krylov iteration
    // on its whole copy of the model (matrix_free is not distributed). Teuchos's SerialComm
    // crashes MueLu 13.2's hierarchy set-up; an MPI communicator of one process does not.
    m_comm = rcp(new Teuchos::MpiComm<int>(Teuchos::opaqueWrapper(MPI_COMM_SELF)));
  }

  void analyzePattern(const SparseMatrix& P) override {
    m_info = Eigen::Success;
    m_copy.analyze(P, m_layout, m_comm);
    m_in = rcp(new mv_t(m_copy.map, 1));
    m_out = rcp(new mv_t(m_copy.map, 1));
    release_factor();
  }

  void factorize(const SparseMatrix& P) override {
    m_info = Eigen::Success;
    if (!m_copy.analyzed()) analyzePattern(P);
    m_copy.fill(P);
    set_up();
  }

  void release_factor() override {
    m_cycle.reset();
    m_muelu = Teuchos::null;
  }

  /// P's values into the hierarchy's matrix, then P freed: the set-up, the peak of a
  /// million-particle run, never holds both. The set-up itself waits for set_up_loaded().
  void load(SparseMatrix& P) override {
    m_info = Eigen::Success;
    release_factor();
    if (!m_copy.analyzed()) analyzePattern(P);
    m_copy.fill(P);
    release(P);
    m_loaded = true;
  }
  void set_up_loaded() override {
    if (m_loaded) set_up();
  }

  void solve(VectorIn b, VectorXd& x) override {
    set_up_loaded();
    if (m_muelu.is_null() && !m_cycle) {  // no hierarchy (a failed set-up): the caller sees info()
      m_info = Eigen::NumericalIssue;
      return;
    }
    const Distribution& d = m_copy.d;
    const LO local = d.local_rows();
    {
      const Teuchos::ArrayRCP<double> in = m_in->getDataNonConst(0);
      for (LO r = 0; r < local; ++r) in[r] = d.unknown_of_local[r] >= 0 ? b[d.unknown_of_local[r]] : 0.0;
    }
    if (m_cycle)
      m_cycle->apply(m_in->getData(0).getRawPtr(), m_out->getDataNonConst(0).getRawPtr());
    else
      m_muelu->apply(*m_in, *m_out);
    x.resize(b.size());
    const Teuchos::ArrayRCP<const double> out = m_out->getData(0);
    for (LO r = 0; r < local; ++r)
      if (d.unknown_of_local[r] >= 0) x[d.unknown_of_local[r]] = out[r];
  }

  Eigen::ComputationInfo info() const override { return m_info; }
  /// "muelu", or "muelu-serial" when MueLu applies the cycle on one core (not threaded, or a
  /// hierarchy the threaded cycle does not repeat).
  std::string name() const override { return m_muelu.is_null() || m_cycle ? "muelu" : "muelu-serial"; }
  long factorizations() const override { return m_builds; }
  double matrix_bytes_per_solve() const override { return m_cycle ? m_cycle->matrix_bytes_per_apply() : 0.0; }
  /// The threaded GMRES cycle pre-smooths with degree 1, post-smooths with 2 (set_up()).
  bool symmetric() const override { return !(m_cycle && m_light_pre); }

 private:
  /// MueLu's hierarchy of the filled copy, and its threaded cycle.
  void set_up() {
    m_loaded = false;
    ++m_builds;
    try {
      // The old hierarchy goes before the new one is built: at a million particles the two
      // together were the run's peak (9.1 against 8.1 GB). Rebuilding in place ("reuse: type"
      // RP with ReuseTpetraPreconditioner) saved set-up time at 300 x 300 but held 0.3 GB more
      // and threw at 1000 x 1000.
      release_factor();
      Teuchos::ParameterList p;
      p.set("verbosity", "none");
      // As belos's muelu (its measurements): Chebyshev smoothing, a relaxed coarsest level.
      p.set("smoother: type", "CHEBYSHEV");
      // Chebyshev degree 2 where the tangents may be unsymmetric (frictional contact: the
      // cycle serves GMRES while pairs slip), 1 otherwise (CG). Measured at paper resolution
      // (docs/performance.md, "The V-cycle"), degree 2 against 1: Krylov iterations 4.1
      // 301 -> 206 (wall 3.33 -> 3.01 s, medians of 6), 4.4 2690 -> 2244, 4.2 3.2 -> 2.6 s,
      // 4.3 the same wall; but the symmetric ones take more: the frictionless LEFM case
      // 150 -> 165 (5.1 -> 6.0 s), the tension plate 400 x 400 218 -> 239. The threaded
      // cycle applies the degree-2 pre-smoothers with degree 1 (below); MueLu's own apply
      // (CycleApply::muelu, and a hierarchy the threads cannot repeat) keeps 2 before and
      // after, a symmetric cycle.
      p.sublist("smoother: params").set("chebyshev: degree", m_gmres ? 2 : 1);
      p.set("coarse: type", "RELAXATION");
      p.set("coarse: max size", 100);
      // R = P^T applied, not stored: 20 MB of 862 MB at 300 x 300, the same iterations.
      p.set("transpose: use implicit", true);
      // Aggregates ignore couplings weaker than 0.02 of their rows' diagonals (the contact
      // pairs' blocks mostly): at paper resolution 4.2 2.75 -> 1.55 s (Krylov 782 -> 432), 4.1
      // 4.22 -> 3.86 s, 4.3 1.00 -> 0.83 s; the tension plate unchanged (300 x 300 and
      // 1000 x 1000: the same time, memory and iterations). 0.01 and 0.03-0.05 gain less,
      // 0.1 costs 4-8 times the iterations.
      p.set("aggregation: drop tol", 0.02);
      // ... but the prolongator is smoothed with the whole matrix, not a filtered copy: one
      // matrix fewer to build. Case 4.3 at paper resolution: Krylov 221 -> 241 with one set-up
      // fewer (0.24 -> 0.14 s of set-up); tension 300 x 300, one step: set-up 2.0 -> 1.5 s; the
      // LEFM case 169 -> 150 Krylov; 4.1, 4.2 and 4.4 within 2 iterations.
      p.set("sa: use filtered matrix", false);
      // Above kAmgMemoryFirstRows the Galerkin product P^T A P is formed without the temporary
      // A P, which made the set-up the run's peak: 1000 x 1000, peak 7.97 -> 7.54 GB (1e9 B)
      // before the eighth round; 700 x 700, 3.96 -> 3.77 GB for 8.5 -> 10.3 s of set-up.
      // Below, time counts more.
      p.set("rap: triple product", m_copy.d.n_rows > kAmgMemoryFirstRows);
      if (m_copy.d.per_node == 2) {
        p.set("number of equations", 2);
        p.sublist("user data").set("Nullspace", m_copy.rigid_body_modes(m_layout));
      }
      m_muelu = MueLu::CreateTpetraPreconditioner(RCP<op_t>(m_copy.matrix), p);
      // The cycle on this program's threads (MueLu's apply runs on one core: Debian's Kokkos
      // is Serial only); a hierarchy it cannot repeat is applied by MueLu, and said so in name().
      // Its finest level in 2 x 2 blocks, of floats by default (ThreadedCycle::Blocks), which
      // replace the copy's CSR values (below).
      if (m_apply != CycleApply::muelu) {
        using Finest = ThreadedCycle::Finest;
        const bool blocked = m_copy.d.per_node == 2;
        const Finest finest =
            !blocked ? Finest::csr : m_apply == CycleApply::threads ? Finest::float_blocks : Finest::blocks;
        // For GMRES, degree 1 before (from the cycle's zero guess D^-1 b scaled, no product)
        // and MueLu's 2 after: the finest matrix read three times a cycle instead of four, for
        // as many Krylov iterations or fewer (docs/performance.md, "Crack growth at dx =
        // 0.01 m"). Not symmetric: a symmetric solve with it runs GMRES (symmetric()).
        m_light_pre = m_gmres && m_apply == CycleApply::threads;
        m_cycle = ThreadedCycle::from(*m_muelu->GetHierarchy(), m_why_not, finest, m_light_pre ? 1 : 0);
        // The threaded cycle holds the levels' matrices it reads (Kokkos views count their
        // owners): MueLu's hierarchy, its smoothers' vectors and near-null spaces go (22 MB
        // at 500 x 500).
        if (m_cycle) m_muelu = Teuchos::null;
        // Its blocks are all it reads of the finest matrix: the copy's values go too (8 bytes
        // per entry against the blocks' 5) until the next fill().
        if (m_cycle && finest != Finest::csr) m_copy.release_values();
      }
    } catch (const std::exception&) {  // a Trilinos failure (e.g. a zero pivot): the seam's terms
      release_factor();
      m_info = Eigen::NumericalIssue;
    }
  }

  RCP<const Teuchos::Comm<int>> m_comm;
  UnknownLayout m_layout;
  TpetraCopy m_copy;
  RCP<mv_t> m_in, m_out;
  RCP<MueLu::TpetraOperator<double, LO, GO, NT>>
      m_muelu;  ///< null once the threaded cycle holds what it reads
  CycleApply m_apply;
  bool m_loaded = false;  ///< load() filled m_copy for a set-up not built yet
  bool m_gmres = false;   ///< the cycle may serve GMRES (LinearSetup::may_be_unsymmetric): Chebyshev degree 2
  bool m_light_pre = false;                ///< the threaded cycle pre-smooths with degree 1 (GMRES's)
  std::unique_ptr<ThreadedCycle> m_cycle;  ///< m_muelu's cycle on this program's threads, or null
  std::string m_why_not;                   ///< why the last hierarchy has no threaded cycle
  long m_builds = 0;
  Eigen::ComputationInfo m_info = Eigen::Success;
};

}  // namespace

std::unique_ptr<Preconditioner> make_muelu_cycle(const LinearSetup& setup, CycleApply apply) {
  return std::make_unique<MueLuCycle>(setup, apply);
}

}  // namespace peristat
