#include "solvers/linear/preconditioner.hpp"

#include <map>

#include "core/error.hpp"

namespace peristat {

namespace {

/// A direct solver's factor of P as the preconditioner: M^-1 b is its solve.
class FactorPreconditioner final : public Preconditioner {
 public:
  explicit FactorPreconditioner(std::unique_ptr<LinearSolver> factor) : m_factor(std::move(factor)) {}
  void analyzePattern(const SparseMatrix& P) override { m_factor->analyzePattern(P); }
  void factorize(const SparseMatrix& P) override { m_factor->factorize(P); }
  /// The factor's solve takes a whole vector: b is copied into one kept for it.
  void solve(VectorIn b, VectorXd& x) override {
    m_b = b;
    m_factor->solve(m_b, x);
  }
  Eigen::ComputationInfo info() const override { return m_factor->info(); }
  std::string name() const override { return m_factor->name(); }
  long factorizations() const override { return m_factor->stats().factorizations; }
  bool exact() const override { return true; }

 private:
  std::unique_ptr<LinearSolver> m_factor;
  VectorXd m_b;
};

/// The registered makers (register_preconditioner), set once at start-up.
std::map<PreconditionerKind, PreconditionerMaker>& makers() {
  static std::map<PreconditionerKind, PreconditionerMaker> registered;
  return registered;
}

}  // namespace

std::unique_ptr<Preconditioner> factor_preconditioner(std::unique_ptr<LinearSolver> factor) {
  return std::make_unique<FactorPreconditioner>(std::move(factor));
}

void register_preconditioner(PreconditionerKind kind, PreconditionerMaker make) { makers()[kind] = make; }

std::unique_ptr<Preconditioner> make_registered_preconditioner(PreconditionerKind kind, const LinearSetup& setup) {
  const auto found = makers().find(kind);
  if (found == makers().end())
    throw InputError("solver.krylov.preconditioner: '" + std::string(to_string(kind)) +
                     "' is not available in this program (no maker registered)");
  return found->second(setup);
}

}  // namespace peristat
