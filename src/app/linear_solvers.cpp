#include "app/linear_solvers.hpp"

#include <utility>

#include "app/setup.hpp"
#include "solvers/linear/preconditioner.hpp"
#include "solvers/trilinos/belos_solver.hpp"

namespace peristat {

namespace {

/// The quasi-static problem as the linear system: its tangent's action, the entries that
/// action reads, and the bond matrix P at the state of its last evaluation.
class ProblemSystem final : public LinearSystem {
 public:
  explicit ProblemSystem(QuasiStaticProblem& problem) : m_problem(problem) {}
  void apply(const VectorXd& v, VectorXd& y) override { m_problem.apply_tangent(v, y); }
  std::vector<Index> reads() const override { return m_problem.action_reads(); }
  void preconditioner(SparseMatrix& P) override {
    if (P.rows() == 0) take(P, m_problem.make_preconditioner());
    m_problem.assemble_preconditioner(P);
  }
  bool suspend_action() override { return m_problem.suspend_action(); }
  void resume_action() override { m_problem.resume_action(); }
  bool contact_zone_rows(SparseMatrix& Pz) override { return m_problem.assemble_contact_zone(Pz); }

 private:
  QuasiStaticProblem& m_problem;
};

std::unique_ptr<LinearSolver> make_belos(const LinearOptions& options, LinearSetup setup) {
  return make_belos_solver(options.belos, std::move(setup));
}

std::unique_ptr<Preconditioner> make_bond_amg(const LinearSetup& setup) { return make_muelu_cycle(setup); }

}  // namespace

void register_linear_solvers() {
  register_linear_solver(LinearSolverKind::belos, make_belos);
  register_preconditioner(PreconditionerKind::bond_amg, make_bond_amg);
}

std::unique_ptr<LinearSolver> make_problem_linear_solver(const Scene& scene, QuasiStaticProblem& problem,
                                                         const LinearOptions& options, const ModelPart* part) {
  register_linear_solvers();
  LinearSetup setup;
  if (part) {
    setup.layout = part_unknown_layout(*part, problem.ranks());
  } else if (needs_unknown_layout(options)) {
    setup.layout = unknown_layout(problem.model(), problem.n_unknowns());
  }
  setup.may_be_unsymmetric = scene.contact.enabled && scene.contact.friction > 0.0;  // pairs may slip
  setup.system = std::make_shared<ProblemSystem>(problem);
  return make_linear_solver(options, std::move(setup));
}

}  // namespace peristat
