// When a Krylov solver renews the preconditioner it keeps across Newton iterations and load
// steps (a factor, an algebraic multigrid hierarchy):
// - once a solve needs more than kRefreshGrowth * n + kRefreshSlack iterations, n the
//   iterations the first solve with it would have needed for this solve's reduction of the
//   residual (its iterations per decade times this solve's decades), if the problem's
//   discrete state (contact active set, broken bonds) has changed since it was built;
// - at once when a solve does not converge with a preconditioner that has served before.
// docs/theory/newton.md, "Factor-preconditioned Krylov (`cg`)". Shared by `cg` and `belos`.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>

namespace peristat {

class PreconditionerReuse {
 public:
  /// A heuristic: renew when the iterations per decade of residual reduction have doubled;
  /// the slack keeps a preconditioner whose first solve took only a few iterations from being
  /// renewed over a few more.
  /// - Per decade, because inexact Newton asks for more decades as it converges (the forcing
  ///   term falls from 1e-3 towards krylov.rtol).
  /// - Only after the discrete state changed: the first solve is often the load step's
  ///   predictor, whose right-hand side (the load increment's residual) is smoother than a
  ///   Newton correction's. The tension plate at 1000 x 1000 needed 14, then 62 iterations
  ///   with the same preconditioner, and a new one saved no iteration for 23 s of set-up.
  static constexpr int kRefreshGrowth = 2;
  static constexpr int kRefreshSlack = 5;
  /// Decades credited to a solve whose achieved relative residual is 0 (an exact answer) or
  /// not finite, and the fewest credited to one that barely reduced it.
  static constexpr double kMaxDecades = 16.0;
  static constexpr double kMinDecades = 0.5;

  /// log10(1 / error): the decades by which a solve reduced the relative residual.
  static double decades(double error) {
    if (!(error > 0.0) || !std::isfinite(error)) return kMaxDecades;
    return std::clamp(-std::log10(error), kMinDecades, kMaxDecades);
  }

  /// A new preconditioner was built (call from the build function).
  void built() {
    m_due = false;
    m_fresh = true;
    m_built_state = m_state;
  }
  /// True when the next factorize() should build a new one.
  bool due() const { return m_due; }
  /// The next factorize() builds a new one (a new pattern, say).
  void renew() { m_due = true; }
  /// The problem's traits().preconditioner_state at the next solve.
  void set_state(std::uint64_t state) { m_state = state; }

  /// One solve: build() when there is no preconditioner (`have` false), run(), and once more
  /// with a fresh one when a used one did not converge; then decide whether the next
  /// factorize() renews it. build() and run() report through `info`; run() through
  /// `iterations` and `error` (the achieved relative residual).
  template <class Build, class Run>
  void solve(bool have, Build&& build, Run&& run, const Eigen::ComputationInfo& info, const int& iterations,
             const double& error) {
    if (!have) build();
    if (info != Eigen::Success) return;
    run();
    if (info == Eigen::NoConvergence && !m_fresh) {
      build();
      if (info != Eigen::Success) return;
      run();
    }
    if (m_fresh) {
      m_fresh_per_decade = iterations / decades(error);
      m_fresh = false;
    } else if (m_state != m_built_state &&
               iterations > kRefreshGrowth * m_fresh_per_decade * decades(error) + kRefreshSlack) {
      m_due = true;
    }
  }

 private:
  bool m_due = true, m_fresh = false;
  double m_fresh_per_decade = 0.0;               ///< iterations per decade of the first solve with it
  std::uint64_t m_state = 0, m_built_state = 0;  ///< the problem's discrete state: now, and at the build
};

}  // namespace peristat
