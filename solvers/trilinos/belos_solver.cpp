// solver.linear: belos. Trilinos's Krylov solvers (Belos) on the Tpetra copy of the tangent
// (solvers/trilinos/tpetra_adapter.hpp) or its action, preconditioned by the choice of
// solver.belos.preconditioner (solvers/trilinos/belos_preconditioner.hpp).
#include "solvers/trilinos/belos_solver.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <BelosLinearProblem.hpp>
#include <BelosSolverFactory.hpp>
#include <BelosTpetraAdapter.hpp>
#include <Teuchos_XMLParameterListHelpers.hpp>
#include <Tpetra_Core.hpp>

#include "core/error.hpp"
#include "solvers/linear/preconditioner_reuse.hpp"
#include "solvers/trilinos/belos_preconditioner.hpp"
#include "solvers/trilinos/tpetra_start.hpp"
#include "solvers/trilinos/tpetra_adapter.hpp"

namespace peristat {

namespace {

using namespace tpetra;

std::string first_line(const std::string& text) { return text.substr(0, text.find('\n')); }

class BelosSolver final : public LinearSolver {
 public:
  BelosSolver(const BelosOptions& o, LinearSetup setup)
      : m_options(o), m_layout(std::move(setup.layout)), m_system(std::move(setup.system)) {
    parallel::ensure_started();
    m_comm = Tpetra::getDefaultComm();
    if (!o.muelu_parameters.empty()) {
      try {
        Teuchos::updateParametersFromXmlFile(o.muelu_parameters, Teuchos::inOutArg(m_muelu_parameters));
      } catch (const std::exception& e) {
        throw InputError("solver.belos.muelu_parameters: \"" + o.muelu_parameters +
                         "\" is not a Teuchos XML parameter list: " + first_line(e.what()));
      }
    }
  }

  void analyzePattern(const SparseMatrix& A) override {
    m_info = Eigen::Success;
    if (uses_preconditioner_matrix()) {  // a new pattern of P too; with a matrix-free tangent it comes first
      release(m_P);
      if (m_system) m_system->preconditioner(m_P);
      m_P_fresh = true;
    }
    if (matrix_free() && m_P.rows() == 0) {  // the copy is the bond matrix's
      m_info = Eigen::InvalidInput;
      return;
    }
    m_copy.analyze(matrix_free() ? m_P : A, m_layout, m_comm);
    if (!m_layout.part()) {  // the whole solution on every rank after each solve
      m_replicated = rcp(new map_t(static_cast<Tpetra::global_size_t>(m_copy.d.n_rows), GO(0), m_comm,
                                   Tpetra::LocallyReplicated));
      m_import = rcp(new import_t(m_copy.map, m_replicated));
      m_X_all = rcp(new mv_t(m_replicated, 1));
    }
    m_X = rcp(new mv_t(m_copy.map, 1));
    m_B = rcp(new mv_t(m_copy.map, 1));
    m_problem = rcp(new Belos::LinearProblem<double, mv_t, op_t>());
    if (matrix_free())
      m_tangent = rcp(new TangentOperator(m_copy.map, m_system->reads(), m_copy.d, *m_system, m_copy.padding));
    m_preconditioners.drop(true);
    m_reuse.renew();
  }

  /// The assembled tangent's copy takes A; a due preconditioner is built (with P at this state).
  void factorize(const SparseMatrix& A) override {
    m_info = Eigen::Success;
    if (m_copy.matrix.is_null()) analyzePattern(A);
    if (m_info != Eigen::Success) return;
    if (!matrix_free()) m_copy.fill(A);
    if (m_reuse.due()) build_preconditioner();
  }

  void solve(const VectorXd& b, VectorXd& x) override {
    const Index n = static_cast<Index>(b.size());
    if (x.size() != n) x = VectorXd::Zero(n);
    m_iterations = 0;
    m_error = 0.0;
    if (rhs_is_zero(b)) {
      x.setZero();
      m_info = Eigen::Success;
      return;
    }
    m_reuse.solve(
        !m_preconditioners.get().is_null(), [&] { build_preconditioner(); }, [&] { run(b, x); }, m_info,
        m_iterations, m_error);
  }

  Eigen::ComputationInfo info() const override { return m_info; }
  LinearSolverTraits traits() const override {
    return {"belos-" + std::string(to_string(m_options.method)) + "+" +
                std::string(to_string(m_options.preconditioner)) + (matrix_free() ? "+matrix_free" : ""),
            m_options.method == BelosMethod::cg, true};
  }
  LinearSolverStats stats() const override { return {m_iterations, m_error, m_builds, 0.0}; }
  void configure(const LinearSolve& next) override {
    m_symmetric = next.symmetric;
    m_rtol = std::max(next.rtol, m_options.rtol);
    m_reuse.set_state(next.state);
  }
  void renew_preconditioner() override { m_reuse.renew(); }

 private:
  bool matrix_free() const { return m_options.tangent == BelosTangent::matrix_free; }
  /// The bond matrix: the bond factor's, and with a matrix-free tangent every preconditioner's.
  bool uses_preconditioner_matrix() const {
    return m_options.preconditioner == BelosPreconditioner::bond_factor || matrix_free();
  }

  /// Whether b is zero on every rank: on a part, over every rank's own rows (collective), so
  /// that no rank returns while the others solve.
  bool rhs_is_zero(const VectorXd& b) const {
    if (!m_layout.part()) return b.norm() == 0.0;
    double owned = 0.0;
    for (const Index k : m_copy.d.unknown_of_local)
      if (k >= 0) owned = std::max(owned, std::abs(b[k]));
    return parallel::max_over_ranks(owned) == 0.0;
  }

  /// A new preconditioner from P at the state of the last evaluation (like A's), as in one
  /// process (factor_krylov.cpp): the old hierarchy goes first, from the Belos problem too (the
  /// set-up would otherwise hold two: 0.14 GB of a 1.52 GB peak, 700 x 700 on four ranks); P is
  /// assembled, copied, and dropped before the set-up unless the bond factor reads it (54 MB of a
  /// rank's peak).
  void build_preconditioner() {
    m_reuse.built();
    m_preconditioners.drop(false);
    if (!m_problem.is_null()) m_problem->setRightPrec(Teuchos::null);
    const bool bond_factor = m_options.preconditioner == BelosPreconditioner::bond_factor;
    if (uses_preconditioner_matrix() && !m_P_fresh && m_system) m_system->preconditioner(m_P);
    m_P_fresh = false;
    if (matrix_free()) m_copy.fill(m_P);
    if (!bond_factor) release(m_P);
    ++m_builds;
    m_info = m_preconditioners.build(m_options.preconditioner, m_copy, m_layout, m_muelu_parameters,
                                     m_P.rows() > 0 ? &m_P : nullptr);
  }

  void run(const VectorXd& b, VectorXd& x) {
    const Distribution& d = m_copy.d;
    const LO local = d.local_rows();
    {
      const Teuchos::ArrayRCP<double> bl = m_B->getDataNonConst(0), xl = m_X->getDataNonConst(0);
      for (LO r = 0; r < local; ++r) {
        const Index k = d.unknown_of_local[r];
        bl[r] = k >= 0 ? b[k] : 0.0;
        xl[r] = k >= 0 ? x[k] : 0.0;
      }
    }
    const bool cg = m_options.method == BelosMethod::cg || (m_options.method == BelosMethod::automatic && m_symmetric);
    RCP<Belos::SolverManager<double, mv_t, op_t>>& solver = cg ? m_cg : m_gmres;
    double& applied = cg ? m_cg_rtol : m_gmres_rtol;  // the tolerance the solver holds
    try {
      if (!solver.is_null() && applied != m_rtol) {  // a new forcing term (Newton's)
        RCP<Teuchos::ParameterList> p = rcp(new Teuchos::ParameterList(*solver->getCurrentParameters()));
        p->set("Convergence Tolerance", m_rtol);
        solver->setParameters(p);
        applied = m_rtol;
      }
      if (solver.is_null()) {
        RCP<Teuchos::ParameterList> p = rcp(new Teuchos::ParameterList);
        p->set("Convergence Tolerance", m_rtol);
        applied = m_rtol;
        p->set("Maximum Iterations", m_options.max_iterations);
        if (cg) {
          p->set("Assert Positive Definiteness", false);  // a breakdown is reported, not thrown
          p->set("Residual Scaling", "Norm of RHS");
        } else {
          p->set("Num Blocks", m_options.restart);
          p->set("Maximum Restarts", m_options.max_iterations / m_options.restart + 1);
          p->set("Implicit Residual Scaling", "Norm of RHS");
          p->set("Explicit Residual Scaling", "Norm of RHS");
        }
        Belos::SolverFactory<double, mv_t, op_t> factory;
        solver = factory.create(cg ? "CG" : "GMRES", p);
      }
      m_problem->setOperator(matrix_free() ? RCP<op_t>(m_tangent) : RCP<op_t>(m_copy.matrix));
      m_problem->setRightPrec(m_preconditioners.get());
      m_problem->setProblem(m_X, m_B);
      solver->setProblem(m_problem);
      const Belos::ReturnType result = solver->solve();
      m_iterations = solver->getNumIters();
      m_error = solver->achievedTol();
      m_info = result == Belos::Converged ? Eigen::Success : Eigen::NoConvergence;
    } catch (const std::exception&) {
      m_info = Eigen::NumericalIssue;
      return;
    }
    if (m_layout.part()) {  // a rank's part: its own unknowns; the caller imports its ghosts
      const Teuchos::ArrayRCP<const double> own = m_X->getData(0);
      for (LO r = 0; r < local; ++r)
        if (d.unknown_of_local[r] >= 0) x[d.unknown_of_local[r]] = own[r];
      return;
    }
    // Every rank gets the whole solution: the model above the seam is the same on all ranks.
    m_X_all->doImport(*m_X, *m_import, Tpetra::INSERT);
    const Teuchos::ArrayRCP<const double> all = m_X_all->getData(0);
    for (Index k = 0; k < static_cast<Index>(x.size()); ++k) x[k] = all[d.row_of[k]];
  }

  BelosOptions m_options;
  Teuchos::ParameterList m_muelu_parameters;  ///< solver.belos.muelu_parameters, or empty
  RCP<const Teuchos::Comm<int>> m_comm;
  UnknownLayout m_layout;
  std::shared_ptr<LinearSystem> m_system;  ///< the tangent's action (matrix-free) and the bond matrix
  /// The bond matrix (bond_factor, a matrix-free tangent): from analyzePattern() to the next
  /// build, and kept after it for the bond factor only.
  SparseMatrix m_P;
  bool m_P_fresh = false;  ///< analyzePattern() filled m_P at this state: factorize() need not again
  TpetraCopy m_copy;  ///< of the tangent, or with a matrix-free tangent of the bond matrix
  RCP<TangentOperator> m_tangent;
  RCP<const map_t> m_replicated;
  RCP<import_t> m_import;
  RCP<mv_t> m_X, m_B, m_X_all;
  RCP<Belos::LinearProblem<double, mv_t, op_t>> m_problem;
  RCP<Belos::SolverManager<double, mv_t, op_t>> m_cg, m_gmres;
  BelosPreconditioners m_preconditioners;
  bool m_symmetric = true;
  /// The relative residual of the next solves (solver.belos.rtol, or Newton's looser forcing
  /// term), and the one the CG and GMRES solver managers were last given.
  double m_rtol = m_options.rtol, m_cg_rtol = -1.0, m_gmres_rtol = -1.0;
  PreconditionerReuse m_reuse;
  int m_iterations = 0;
  double m_error = 0.0;
  long m_builds = 0;
  Eigen::ComputationInfo m_info = Eigen::Success;
};

}  // namespace

std::unique_ptr<LinearSolver> make_belos_solver(const BelosOptions& options, LinearSetup setup) {
  return std::make_unique<BelosSolver>(options, std::move(setup));
}

}  // namespace peristat
