#include "solvers/linear/linear_solver.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/KLUSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/UmfPackSupport>

#include <algorithm>
#include <stdexcept>

#include "core/error.hpp"
#include "solvers/linear/factor_krylov.hpp"
#include "solvers/trilinos/belos_solver.hpp"

namespace peristat {

std::string describe(Eigen::ComputationInfo info) {
  switch (info) {
    case Eigen::Success:
      return "success";
    case Eigen::NumericalIssue:
      return "numerical issue (the matrix is singular or not positive definite: is every "
             "body held against rigid motion? With contact, the pair terms can make the tangent "
             "indefinite or nearly singular: solver.linear=cg copes)";
    case Eigen::NoConvergence:
      return "the iterative solver did not converge";
    case Eigen::InvalidInput:
      return "invalid input";
  }
  return "unknown";
}

namespace {

/// What every Eigen sparse solver shares behind LinearSolver: analyzePattern, factorize
/// (counted), info, the name and whether it needs a symmetric matrix. Subclasses add solve.
template <class Solver>
class EigenSolverAdapter : public LinearSolver {
 public:
  EigenSolverAdapter(std::string name, bool symmetric) : m_name(std::move(name)), m_symmetric(symmetric) {
    // CHOLMOD prints its warnings ("matrix not positive definite") on stderr by itself; the
    // failure reaches the user through info() and describe(), in the run's own words.
    if constexpr (requires(Solver& s) { s.cholmod(); }) m_solver.cholmod().print = 0;
  }
  void analyzePattern(const SparseMatrix& A) final {
    m_solver.analyzePattern(A);
    m_info = m_solver.info();
  }
  void factorize(const SparseMatrix& A) final {
    m_solver.factorize(A);
    m_info = m_solver.info();
    ++m_factorizations;
  }
  long factorizations() const final { return m_factorizations; }
  Eigen::ComputationInfo info() const final { return m_info; }
  std::string name() const final { return m_name; }
  bool needs_symmetric() const final { return m_symmetric; }

 protected:
  Solver m_solver;
  Eigen::ComputationInfo m_info = Eigen::Success;

 private:
  std::string m_name;
  bool m_symmetric;
  long m_factorizations = 0;
};

/// Any Eigen sparse direct solver (CHOLMOD, UMFPACK, KLU, SimplicialLDLT).
template <class Solver>
class DirectSolver final : public EigenSolverAdapter<Solver> {
 public:
  using EigenSolverAdapter<Solver>::EigenSolverAdapter;
  void solve(const VectorXd& b, VectorXd& x) override {
    x = this->m_solver.solve(b);
    this->m_info = this->m_solver.info();
  }
};

/// Any Eigen Krylov solver; factorize() builds the preconditioner, solve() starts from x.
template <class Solver>
class KrylovSolver final : public EigenSolverAdapter<Solver> {
 public:
  KrylovSolver(std::string name, bool symmetric, const LinearOptions& options)
      : EigenSolverAdapter<Solver>(std::move(name), symmetric), m_floor(options.rtol) {
    this->m_solver.setTolerance(options.rtol);
    this->m_solver.setMaxIterations(options.max_iterations);
  }
  bool iterative() const override { return true; }
  void set_relative_tolerance(double rtol) override { this->m_solver.setTolerance(std::max(rtol, m_floor)); }
  void solve(const VectorXd& b, VectorXd& x) override {
    if (x.size() != b.size()) x = VectorXd::Zero(b.size());
    x = this->m_solver.solveWithGuess(b, x);
    this->m_info = this->m_solver.info();
  }
  int iterations() const override { return static_cast<int>(this->m_solver.iterations()); }
  double error() const override { return this->m_solver.error(); }

 private:
  double m_floor;  ///< the configured rtol (solver.krylov.rtol)
};

using Full = SparseMatrix;
constexpr int kBoth = Eigen::Lower | Eigen::Upper;

}  // namespace

std::unique_ptr<LinearSolver> make_linear_solver(const LinearOptions& o) {
  using LS = LinearSolverKind;
  using PC = PreconditionerKind;
  const LS t = o.type;
  const PC pc = o.preconditioner != PC::automatic ? o.preconditioner
                : t == LS::bicgstab               ? PC::ilut
                : t == LS::matrix_free            ? PC::bond_amg
                                                  : PC::bond;
  auto not_available = [&](const char* expected) {
    return InputError("solver.krylov.preconditioner: '" + std::string(to_string(pc)) +
                      "' is not available with " + std::string(to_string(t)) + ": expected " + expected);
  };
  switch (t) {
    case LS::cholmod:
      return std::make_unique<DirectSolver<Eigen::CholmodSupernodalLLT<Full, Eigen::Lower>>>("cholmod", true);
    case LS::umfpack:
      return std::make_unique<DirectSolver<Eigen::UmfPackLU<Full>>>("umfpack", false);
    case LS::klu:
      return std::make_unique<DirectSolver<Eigen::KLU<Full>>>("klu", false);
    case LS::ldlt:
      return std::make_unique<DirectSolver<Eigen::SimplicialLDLT<Full, Eigen::Lower>>>("ldlt", true);
    case LS::cg:
      if (pc == PC::bond_amg)
        return make_factor_preconditioned_krylov(make_muelu_cycle(), FactorSource::preconditioner_matrix, o);
      if (pc == PC::bond || pc == PC::cholmod) {
        auto factor =
            std::make_unique<DirectSolver<Eigen::CholmodSupernodalLLT<Full, Eigen::Lower>>>("cholmod", true);
        const auto source =
            pc == PC::bond ? FactorSource::preconditioner_matrix : FactorSource::system_matrix;
        return make_factor_preconditioned_krylov(std::move(factor), source, o);
      }
      if (pc == PC::ic)
        return std::make_unique<KrylovSolver<Eigen::ConjugateGradient<
            Full, kBoth, Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<Index>>>>>(
            "cg+ic", true, o);
      if (pc == PC::diagonal)
        return std::make_unique<
            KrylovSolver<Eigen::ConjugateGradient<Full, kBoth, Eigen::DiagonalPreconditioner<double>>>>(
            "cg+diagonal", true, o);
      throw not_available("bond, bond_amg, cholmod, ic or diagonal");
    case LS::bicgstab:
      if (pc == PC::ilut)
        return std::make_unique<KrylovSolver<Eigen::BiCGSTAB<Full, Eigen::IncompleteLUT<double, Index>>>>(
            "bicgstab+ilut", false, o);
      if (pc == PC::diagonal)
        return std::make_unique<KrylovSolver<Eigen::BiCGSTAB<Full, Eigen::DiagonalPreconditioner<double>>>>(
            "bicgstab+diagonal", false, o);
      throw not_available("ilut or diagonal");
    case LS::belos:
      return make_belos_solver(o.belos);
    case LS::matrix_free:
      if (pc != PC::bond && pc != PC::bond_amg)
        throw not_available("bond or bond_amg (the preconditioners that need no assembled tangent)");
      return make_factor_preconditioned_krylov(
          pc == PC::bond_amg
              ? make_muelu_cycle()
              : std::make_unique<DirectSolver<Eigen::CholmodSupernodalLLT<Full, Eigen::Lower>>>("cholmod", true),
          FactorSource::preconditioner_matrix, o, true);
    case LS::automatic:  // a programming error: the program resolves `auto` before building anything
      throw std::logic_error("make_linear_solver: solver.linear 'auto' was not resolved (choose_linear_solver)");
  }
  throw InputError("solver.linear: unknown linear solver");
}

}  // namespace peristat
