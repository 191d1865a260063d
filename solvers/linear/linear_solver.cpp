#include "solvers/linear/linear_solver.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/KLUSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/UmfPackSupport>

#include "core/error.hpp"
#include "solvers/linear/factor_krylov.hpp"

namespace peristat {

std::string describe(Eigen::ComputationInfo info) {
  switch (info) {
    case Eigen::Success:
      return "success";
    case Eigen::NumericalIssue:
      return "numerical issue (the matrix is singular or not positive definite: is every "
             "body held against rigid motion?)";
    case Eigen::NoConvergence:
      return "the iterative solver did not converge";
    case Eigen::InvalidInput:
      return "invalid input";
  }
  return "unknown";
}

namespace {

/// Any Eigen sparse direct solver (analyzePattern / factorize / solve / info).
template <class Solver>
class DirectSolver final : public LinearSolver {
 public:
  DirectSolver(std::string name, bool symmetric) : m_name(std::move(name)), m_symmetric(symmetric) {}
  void analyzePattern(const SparseMatrix& A) override {
    m_solver.analyzePattern(A);
    m_info = m_solver.info();
  }
  void factorize(const SparseMatrix& A) override {
    m_solver.factorize(A);
    m_info = m_solver.info();
    ++m_factorizations;
  }
  long factorizations() const override { return m_factorizations; }
  void solve(const VectorXd& b, VectorXd& x) override {
    x = m_solver.solve(b);
    m_info = m_solver.info();
  }
  Eigen::ComputationInfo info() const override { return m_info; }
  std::string name() const override { return m_name; }
  bool needs_symmetric() const override { return m_symmetric; }

 private:
  Solver m_solver;
  std::string m_name;
  bool m_symmetric;
  Eigen::ComputationInfo m_info = Eigen::Success;
  long m_factorizations = 0;
};

/// Any Eigen Krylov solver; factorize() builds the preconditioner.
template <class Solver>
class KrylovSolver final : public LinearSolver {
 public:
  KrylovSolver(std::string name, bool symmetric, const LinearOptions& options)
      : m_name(std::move(name)), m_symmetric(symmetric) {
    m_solver.setTolerance(options.rtol);
    m_solver.setMaxIterations(options.max_iterations);
  }
  void analyzePattern(const SparseMatrix& A) override {
    m_solver.analyzePattern(A);
    m_info = m_solver.info();
  }
  void factorize(const SparseMatrix& A) override {
    m_solver.factorize(A);
    m_info = m_solver.info();
    ++m_factorizations;
  }
  long factorizations() const override { return m_factorizations; }
  void solve(const VectorXd& b, VectorXd& x) override {
    if (x.size() != b.size()) x = VectorXd::Zero(b.size());
    x = m_solver.solveWithGuess(b, x);
    m_info = m_solver.info();
  }
  Eigen::ComputationInfo info() const override { return m_info; }
  std::string name() const override { return m_name; }
  bool needs_symmetric() const override { return m_symmetric; }
  int iterations() const override { return static_cast<int>(m_solver.iterations()); }
  double error() const override { return m_solver.error(); }

 private:
  Solver m_solver;
  std::string m_name;
  bool m_symmetric;
  Eigen::ComputationInfo m_info = Eigen::Success;
  long m_factorizations = 0;
};

using Full = SparseMatrix;
constexpr int kBoth = Eigen::Lower | Eigen::Upper;

}  // namespace

std::unique_ptr<LinearSolver> make_linear_solver(const LinearOptions& o) {
  using LS = LinearSolverKind;
  using PC = PreconditionerKind;
  const LS t = o.type;
  const PC pc = o.preconditioner != PC::automatic ? o.preconditioner : t == LS::bicgstab ? PC::ilut : PC::bond;
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
      if (pc == PC::bond || pc == PC::cholmod) {
        auto factor =
            std::make_unique<DirectSolver<Eigen::CholmodSupernodalLLT<Full, Eigen::Lower>>>("cholmod", true);
        const auto source = pc == PC::bond ? FactorSource::preconditioner_matrix : FactorSource::system_matrix;
        return make_factor_preconditioned_krylov(std::move(factor), source, o);
      }
      if (pc == PC::ic)
        return std::make_unique<KrylovSolver<Eigen::ConjugateGradient<
            Full, kBoth, Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<Index>>>>>("cg+ic",
                                                                                                       true, o);
      if (pc == PC::diagonal)
        return std::make_unique<
            KrylovSolver<Eigen::ConjugateGradient<Full, kBoth, Eigen::DiagonalPreconditioner<double>>>>(
            "cg+diagonal", true, o);
      throw not_available("bond, cholmod, ic or diagonal");
    case LS::bicgstab:
      if (pc == PC::ilut)
        return std::make_unique<KrylovSolver<Eigen::BiCGSTAB<Full, Eigen::IncompleteLUT<double, Index>>>>(
            "bicgstab+ilut", false, o);
      if (pc == PC::diagonal)
        return std::make_unique<KrylovSolver<Eigen::BiCGSTAB<Full, Eigen::DiagonalPreconditioner<double>>>>(
            "bicgstab+diagonal", false, o);
      throw not_available("ilut or diagonal");
  }
  throw InputError("solver.linear: unknown linear solver");
}

}  // namespace peristat
