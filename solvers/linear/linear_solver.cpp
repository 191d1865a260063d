#include "solvers/linear/linear_solver.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/KLUSupport>
#include <Eigen/SparseCholesky>
#include <Eigen/UmfPackSupport>

#include <algorithm>
#include <map>
#include <stdexcept>

#include "core/error.hpp"
#include "solvers/linear/factor_krylov.hpp"

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
  Eigen::ComputationInfo info() const final { return m_info; }
  LinearSolverTraits traits() const final { return {m_name, m_symmetric, iterative()}; }
  LinearSolverStats stats() const final { return {iterations(), error(), m_factorizations, 0.0}; }

 protected:
  virtual bool iterative() const { return false; }
  virtual int iterations() const { return 0; }
  virtual double error() const { return 0.0; }

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
  void configure(const LinearSolve& next) override { this->m_solver.setTolerance(std::max(next.rtol, m_floor)); }
  void solve(const VectorXd& b, VectorXd& x) override {
    if (x.size() != b.size()) x = VectorXd::Zero(b.size());
    x = this->m_solver.solveWithGuess(b, x);
    this->m_info = this->m_solver.info();
  }
 private:
  bool iterative() const override { return true; }
  int iterations() const override { return static_cast<int>(this->m_solver.iterations()); }
  double error() const override { return this->m_solver.error(); }

  double m_floor;  ///< the configured rtol (solver.krylov.rtol)
};

using Full = SparseMatrix;
constexpr int kBoth = Eigen::Lower | Eigen::Upper;
using Cholmod = DirectSolver<Eigen::CholmodSupernodalLLT<Full, Eigen::Lower>>;

/// The registered makers (register_linear_solver), set once at start-up.
std::map<LinearSolverKind, LinearSolverMaker>& makers() {
  static std::map<LinearSolverKind, LinearSolverMaker> registered;
  return registered;
}

/// options.preconditioner with `auto` resolved for options.type.
PreconditionerKind preconditioner_of(const LinearOptions& o) {
  using LS = LinearSolverKind;
  using PC = PreconditionerKind;
  return o.preconditioner != PC::automatic ? o.preconditioner
         : o.type == LS::bicgstab          ? PC::ilut
         : o.type == LS::matrix_free       ? PC::bond_amg
                                           : PC::bond;
}

/// The factor or V-cycle of factor-preconditioned Krylov (cg, matrix_free): bond_amg's is
/// registered (Trilinos), the others CHOLMOD's.
std::unique_ptr<Preconditioner> make_factor(PreconditionerKind pc, const LinearSetup& setup) {
  if (pc == PreconditionerKind::bond_amg) return make_registered_preconditioner(pc, setup);
  return factor_preconditioner(std::make_unique<Cholmod>("cholmod", true));
}

std::unique_ptr<LinearSolver> make_cg(const LinearOptions& o, PreconditionerKind pc, LinearSetup& setup) {
  using PC = PreconditionerKind;
  if (pc == PC::bond_amg || pc == PC::bond || pc == PC::cholmod) {
    const auto source = pc == PC::cholmod ? FactorSource::system_matrix : FactorSource::preconditioner_matrix;
    return make_factor_preconditioned_krylov(make_factor(pc, setup), source, o, std::move(setup.system));
  }
  if (pc == PC::ic)
    return std::make_unique<KrylovSolver<Eigen::ConjugateGradient<
        Full, kBoth, Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<Index>>>>>(
        "cg+ic", true, o);
  if (pc == PC::diagonal)
    return std::make_unique<
        KrylovSolver<Eigen::ConjugateGradient<Full, kBoth, Eigen::DiagonalPreconditioner<double>>>>(
        "cg+diagonal", true, o);
  return nullptr;
}

std::unique_ptr<LinearSolver> make_bicgstab(const LinearOptions& o, PreconditionerKind pc) {
  if (pc == PreconditionerKind::ilut)
    return std::make_unique<KrylovSolver<Eigen::BiCGSTAB<Full, Eigen::IncompleteLUT<double, Index>>>>(
        "bicgstab+ilut", false, o);
  if (pc == PreconditionerKind::diagonal)
    return std::make_unique<KrylovSolver<Eigen::BiCGSTAB<Full, Eigen::DiagonalPreconditioner<double>>>>(
        "bicgstab+diagonal", false, o);
  return nullptr;
}

/// The registered maker's solver (belos).
std::unique_ptr<LinearSolver> make_registered(const LinearOptions& o, LinearSetup setup) {
  const auto found = makers().find(o.type);
  if (found == makers().end())
    throw InputError("solver.linear: '" + std::string(to_string(o.type)) +
                     "' is not available in this program (no maker registered)");
  return found->second(o, std::move(setup));
}

}  // namespace

void register_linear_solver(LinearSolverKind kind, LinearSolverMaker make) { makers()[kind] = make; }

bool needs_unknown_layout(const LinearOptions& options) {
  const bool krylov = options.type == LinearSolverKind::cg || options.type == LinearSolverKind::matrix_free;
  return options.type == LinearSolverKind::belos ||
         (krylov && preconditioner_of(options) == PreconditionerKind::bond_amg);
}

std::unique_ptr<LinearSolver> make_linear_solver(const LinearOptions& o, LinearSetup setup) {
  using LS = LinearSolverKind;
  using PC = PreconditionerKind;
  const LS t = o.type;
  const PC pc = preconditioner_of(o);
  auto not_available = [&](const char* expected) {
    return InputError("solver.krylov.preconditioner: '" + std::string(to_string(pc)) +
                      "' is not available with " + std::string(to_string(t)) + ": expected " + expected);
  };
  switch (t) {
    case LS::cholmod:
      return std::make_unique<Cholmod>("cholmod", true);
    case LS::umfpack:
      return std::make_unique<DirectSolver<Eigen::UmfPackLU<Full>>>("umfpack", false);
    case LS::klu:
      return std::make_unique<DirectSolver<Eigen::KLU<Full>>>("klu", false);
    case LS::ldlt:
      return std::make_unique<DirectSolver<Eigen::SimplicialLDLT<Full, Eigen::Lower>>>("ldlt", true);
    case LS::cg:
      if (auto cg = make_cg(o, pc, setup)) return cg;
      throw not_available("bond, bond_amg, cholmod, ic or diagonal");
    case LS::bicgstab:
      if (auto bicgstab = make_bicgstab(o, pc)) return bicgstab;
      throw not_available("ilut or diagonal");
    case LS::belos:
      return make_registered(o, std::move(setup));
    case LS::matrix_free:
      if (pc != PC::bond && pc != PC::bond_amg)
        throw not_available("bond or bond_amg (the preconditioners that need no assembled tangent)");
      return make_factor_preconditioned_krylov(make_factor(pc, setup), FactorSource::preconditioner_matrix, o,
                                               std::move(setup.system), true);
    case LS::automatic:  // a programming error: the program resolves `auto` before building anything
      throw std::logic_error("make_linear_solver: solver.linear 'auto' was not resolved (choose_linear_solver)");
  }
  throw InputError("solver.linear: unknown linear solver");
}

}  // namespace peristat
