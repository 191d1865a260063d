#include "solvers/linear/factor_krylov.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/clock.hpp"
#include "core/scope_exit.hpp"
#include "core/stop.hpp"
#include "solvers/linear/krylov_vectors.hpp"
#include "solvers/linear/preconditioner_reuse.hpp"
#include "solvers/linear/zone_correction.hpp"

namespace peristat {

namespace {

/// y = A x for a symmetric A stored by columns: y_i = column i . x, parallel over columns,
/// deterministic (each y_i is one thread's dot product).
void symmetric_product(const SparseMatrix& A, const VectorXd& x, VectorXd& y) {
  const Index n = static_cast<Index>(A.outerSize());
  const Index* outer = A.outerIndexPtr();
  const Index* inner = A.innerIndexPtr();
  const double* v = A.valuePtr();
  y.resize(n);
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) {
    double s = 0.0;
    for (Index k = outer[i]; k < outer[i + 1]; ++k) s += v[k] * x[inner[k]];
    y[i] = s;
  }
}

/// y = A x for a general A stored by columns (serial scatter).
void general_product(const SparseMatrix& A, const VectorXd& x, VectorXd& y) {
  y.noalias() = A * x;
}

class FactorPreconditionedKrylov final : public LinearSolver {
 public:
  FactorPreconditionedKrylov(std::unique_ptr<Preconditioner> factor, FactorSource source,
                             const LinearOptions& o, std::shared_ptr<LinearSystem> system, bool matrix_free)
      : m_factor(std::move(factor)),
        m_source(source),
        m_matrix_free(matrix_free),
        m_system(std::move(system)),
        m_rtol(o.rtol),
        m_rtol_floor(o.rtol),
        m_max_iterations(o.max_iterations) {}

  void analyzePattern(const SparseMatrix& A) override {
    m_A = &A;
    m_analyzed = false;  // a new pattern (of A, or of the preconditioner matrix)
  }

  /// A due preconditioner takes its matrix now (P at this state, from the source, or A) but
  /// may build at the next solve() (MueLu's hierarchy): the Euler predictor's renewal
  /// (contact pairs it closes) then replaces the set-up at the unloaded state before that
  /// one was ever built (cases 4.1 and 4.3: one set-up fewer).
  void factorize(const SparseMatrix& A) override {
    m_A = &A;
    m_info = Eigen::Success;
    if (!m_reuse.due()) return;
    m_have_factor = false;
    if (m_source == FactorSource::preconditioner_matrix) load_preconditioner_matrix();
  }

  void solve(const VectorXd& b, VectorXd& x) override {
    m_reuse.solve(
        m_have_factor, [&] { refresh_factor(); }, [&] { run(b, x); }, m_info, m_iterations, m_error);
  }

  Eigen::ComputationInfo info() const override { return m_info; }
  /// CG on symmetric matrices, GMRES with the same factor otherwise: needs no symmetric matrix.
  LinearSolverTraits traits() const override {
    const std::string factor = m_factor->name();
    if (m_matrix_free) return {"matrix-free+bond-" + factor, false, true};
    return {m_source == FactorSource::preconditioner_matrix ? "cg+bond-" + factor : "cg+" + factor, false, true};
  }
  LinearSolverStats stats() const override {
    return {m_iterations, m_error, m_factor->factorizations(), m_setup_seconds};
  }
  void configure(const LinearSolve& next) override {
    m_symmetric = next.symmetric;
    m_rtol = std::max(next.rtol, m_rtol_floor);
    m_reuse.set_state(next.state);
    m_state = next.state;
  }
  void renew_preconditioner() override { m_reuse.renew(); }

 private:
  void refresh_factor() {
    const double t0 = wall_seconds();
    if (m_source == FactorSource::preconditioner_matrix) {
      if (!m_loaded) load_preconditioner_matrix();  // a set-up factorize() did not announce
      // The set-up reads the factor's copy of P only: the system's action may go meanwhile.
      const bool suspended = m_system->suspend_action();
      const ScopeExit resume([&] {
        if (suspended) m_system->resume_action();
      });
      m_factor->set_up_loaded();
      m_loaded = false;
    } else {
      if (!m_analyzed) {
        m_factor->analyzePattern(*m_A);
        m_analyzed = true;
      }
      m_factor->factorize(*m_A);
    }
    m_info = m_factor->info();
    m_have_factor = m_info == Eigen::Success;
    m_reuse.built();
    m_setup_seconds += wall_seconds() - t0;
  }

  /// P at the state of the last evaluation (with the tangent, when factorize() calls it)
  /// into the factor, which keeps what it needs; P is dropped here, the factor's old set-up
  /// before P is assembled.
  void load_preconditioner_matrix() {
    if (!m_system) throw std::logic_error("factor-preconditioned Krylov: LinearSetup::system is needed");
    m_factor->release_factor();
    SparseMatrix P;
    m_system->preconditioner(P);
    if (!m_analyzed) {
      m_factor->analyzePattern(P);
      m_analyzed = true;
    }
    m_factor->load(P);
    m_loaded = true;
  }

  void run(const VectorXd& b, VectorXd& x) {
    const Index n = static_cast<Index>(b.size());
    if (x.size() != n) x = VectorXd::Zero(n);
    m_iterations = 0;
    if (b.norm() == 0.0) {
      x.setZero();
      m_error = 0.0;
      m_info = Eigen::Success;
      return;
    }
    if (m_symmetric && m_factor->symmetric())
      run_cg(b, x);
    else  // an unsymmetric system, or a preconditioner CG cannot use
      run_gmres(b, x);
  }

  // Right-preconditioned restarted GMRES(m) (Saad, Iterative Methods, alg. 9.5) with
  // modified Gram-Schmidt and Givens rotations; stops when its estimate of ||b - A x|| (the
  // least-squares residual, equal to the true one in exact arithmetic) is <= rtol ||b||. The
  // residual it minimises is the true one, so it falls monotonically within a cycle. The
  // Gram-Schmidt runs on the threads, with the same bits on any number (KrylovVectors).
  void run_gmres(const VectorXd& b, VectorXd& x) {
    prepare_zone();
    constexpr int m = 60;  // restart length: 60 basis vectors of the unknowns' size
    const double bnorm = b.norm();
    const Index n = static_cast<Index>(b.size());
    if (m_basis.cols() != m + 1 || m_basis.rows() != n) m_basis.resize(n, m + 1);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m + 1, m);  // (m+1) x m Hessenberg, small
    VectorXd cs(m), sn(m), g(m + 1);
    initial_residual(b, x);
    double beta = m_r.norm();
    m_error = beta / bnorm;
    while (m_error > m_rtol && m_iterations < m_max_iterations) {
      m_basis.col(0) = m_r / beta;
      g.setZero();
      g[0] = beta;
      H.setZero();
      int k = 0;
      for (; k < m && m_iterations < m_max_iterations; ++k) {
        throw_if_stop_requested();  // a long solve honours Ctrl-C within an iteration
        m_factor->solve(m_basis.col(k), m_z);
        m_zone.apply(m_basis.col(k), m_z);
        product(m_z, m_q);
        H(k + 1, k) = m_vectors.orthogonalize(m_basis.data(), n, k + 1, m_q.data(), H.col(k).data());
        if (H(k + 1, k) > 0.0) m_basis.col(k + 1) = m_q / H(k + 1, k);
        for (int i = 0; i < k; ++i) {  // previous rotations
          const double t = cs[i] * H(i, k) + sn[i] * H(i + 1, k);
          H(i + 1, k) = -sn[i] * H(i, k) + cs[i] * H(i + 1, k);
          H(i, k) = t;
        }
        const double rr = std::hypot(H(k, k), H(k + 1, k));
        cs[k] = rr > 0.0 ? H(k, k) / rr : 1.0;
        sn[k] = rr > 0.0 ? H(k + 1, k) / rr : 0.0;
        H(k, k) = rr;
        H(k + 1, k) = 0.0;
        g[k + 1] = -sn[k] * g[k];
        g[k] = cs[k] * g[k];
        ++m_iterations;
        m_error = std::abs(g[k + 1]) / bnorm;
        if (m_error <= m_rtol || rr == 0.0) {
          ++k;
          break;
        }
      }
      // x += M^-1 V y with H y = g (upper triangular k x k).
      const VectorXd y = H.topLeftCorner(k, k).triangularView<Eigen::Upper>().solve(g.head(k));
      m_q.noalias() = m_basis.leftCols(k) * y;
      m_factor->solve(m_q, m_z);
      m_zone.apply(m_q, m_z);
      x += m_z;
      // A cycle that ends within the tolerance, or at the iteration limit, ends the solve on
      // its estimate: the caller (Newton) evaluates the true residual of its own problem next,
      // so a product here would only confirm it (one action per solve, of about 5 ms on case
      // 4.4 at dx = 0.01 m). A restart starts from the true residual.
      if (m_error <= m_rtol || m_iterations >= m_max_iterations) break;
      product(x, m_q);
      m_r = b - m_q;
      beta = m_r.norm();
      m_error = beta / bnorm;
    }
    m_info = m_error <= m_rtol && std::isfinite(m_error) ? Eigen::Success : Eigen::NoConvergence;
  }

  /// The contact zone's correction (zone_correction.hpp) after an inexact preconditioner (the
  /// V-cycle), with the system's rows of P of the zone at the problem's current state: made
  /// again when that state changed (active set, broken bonds) or when there was none, kept
  /// otherwise. GMRES's only: the correction makes the preconditioner unsymmetric.
  void prepare_zone() {
    if (m_factor->exact() || !m_system) return;
    if (m_zone.active() && m_state == m_zone_state) return;
    const double t0 = wall_seconds();
    m_zone_state = m_state;
    if (!m_system->contact_zone_rows(m_Pz) || !m_zone.set(m_Pz)) m_zone.clear();
    m_setup_seconds += wall_seconds() - t0;
  }

  // Preconditioned CG (Saad, Iterative Methods, alg. 9.1); stops at ||r|| <= rtol ||b||.
  void run_cg(const VectorXd& b, VectorXd& x) {
    const double bnorm = b.norm();
    initial_residual(b, x);
    m_factor->solve(m_r, m_z);
    m_p = m_z;
    double rz = m_r.dot(m_z);
    m_error = m_r.norm() / bnorm;
    while (m_error > m_rtol && m_iterations < m_max_iterations) {
      throw_if_stop_requested();  // a long solve honours Ctrl-C within an iteration
      product(m_p, m_q);
      const double alpha = rz / m_p.dot(m_q);
      x += alpha * m_p;
      m_r -= alpha * m_q;
      ++m_iterations;
      m_error = m_r.norm() / bnorm;
      if (m_error <= m_rtol) break;
      m_factor->solve(m_r, m_z);
      const double rz_new = m_r.dot(m_z);
      m_p = m_z + (rz_new / rz) * m_p;
      rz = rz_new;
    }
    m_info = m_error <= m_rtol && std::isfinite(m_error) ? Eigen::Success : Eigen::NoConvergence;
  }

  /// m_r = b - A x. Newton's first guess is zero, whose product is zero: m_r is then b
  /// without a product (one action per solve; b - 0 is b, so the same values).
  void initial_residual(const VectorXd& b, const VectorXd& x) {
    if ((x.array() == 0.0).all()) {
      m_r = b;
      return;
    }
    product(x, m_q);
    m_r = b - m_q;
  }

  /// y = A x: the operator (matrix-free), else A's columns (a dot product per column when
  /// A is symmetric, deterministic; a scatter otherwise).
  void product(const VectorXd& x, VectorXd& y) {
    if (m_matrix_free)
      m_system->apply(x, y);
    else if (m_symmetric)
      symmetric_product(*m_A, x, y);
    else
      general_product(*m_A, x, y);
  }

  std::unique_ptr<Preconditioner> m_factor;
  FactorSource m_source;
  bool m_matrix_free;
  std::shared_ptr<LinearSystem> m_system;  ///< the action (matrix-free) and P on demand
  double m_rtol, m_rtol_floor;
  int m_max_iterations;
  const SparseMatrix* m_A = nullptr;
  bool m_loaded = false;    ///< the factor holds P's values for a set-up not built yet
  bool m_analyzed = false, m_have_factor = false, m_symmetric = true;
  PreconditionerReuse m_reuse;
  int m_iterations = 0;
  double m_error = 0.0, m_setup_seconds = 0.0;
  Eigen::ComputationInfo m_info = Eigen::Success;
  VectorXd m_r, m_z, m_p, m_q;  // work vectors, reused across solves
  Eigen::MatrixXd m_basis;      // GMRES Krylov basis (unknowns x 61), reused
  KrylovVectors m_vectors;      // GMRES's Gram-Schmidt on the threads
  ZoneCorrection m_zone;        // GMRES's, after an inexact preconditioner
  SparseMatrix m_Pz;            // the system's rows of the zone, for ZoneCorrection::set
  std::uint64_t m_state = 0, m_zone_state = 0;  // the problem's at this solve, at the zone's
};

}  // namespace

std::unique_ptr<LinearSolver> make_factor_preconditioned_krylov(std::unique_ptr<Preconditioner> factor,
                                                                FactorSource source,
                                                                const LinearOptions& options,
                                                                std::shared_ptr<LinearSystem> system,
                                                                bool matrix_free) {
  return std::make_unique<FactorPreconditionedKrylov>(std::move(factor), source, options, std::move(system),
                                                      matrix_free);
}

}  // namespace peristat
