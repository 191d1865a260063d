// When a Krylov solver renews the preconditioner it keeps across Newton iterations and load
// steps (a factor, an algebraic multigrid hierarchy): once a solve needs more than
// kRefreshGrowth * n + kRefreshSlack iterations, n those of the first solve with it, and at
// once when a solve does not converge with a preconditioner that has served before
// (docs/theory/newton.md, "Factor-preconditioned Krylov (`cg`)"). Shared by `cg` and `belos`.
#pragma once

#include <Eigen/Core>

namespace peristat {

class PreconditionerReuse {
 public:
  /// A heuristic: renew when the count has doubled; the slack keeps a preconditioner whose
  /// first solve took only a few iterations from being renewed over a few more.
  static constexpr int kRefreshGrowth = 2;
  static constexpr int kRefreshSlack = 5;

  /// A new preconditioner was built (call from the build function).
  void built() {
    m_due = false;
    m_fresh = true;
  }
  /// True when the next factorize() should build a new one.
  bool due() const { return m_due; }
  /// The next factorize() builds a new one (a new pattern, say).
  void renew() { m_due = true; }

  /// One solve: build() when there is no preconditioner (`have` false), run(), and once more
  /// with a fresh one when a used one did not converge; then decide whether the next
  /// factorize() renews it. build() and run() report through `info`; run() through `iterations`.
  template <class Build, class Run>
  void solve(bool have, Build&& build, Run&& run, const Eigen::ComputationInfo& info, const int& iterations) {
    if (!have) build();
    if (info != Eigen::Success) return;
    run();
    if (info == Eigen::NoConvergence && !m_fresh) {
      build();
      if (info != Eigen::Success) return;
      run();
    }
    if (m_fresh) {
      m_fresh_iterations = iterations;
      m_fresh = false;
    } else if (iterations > kRefreshGrowth * m_fresh_iterations + kRefreshSlack) {
      m_due = true;
    }
  }

 private:
  bool m_due = true, m_fresh = false;
  int m_fresh_iterations = 0;
};

}  // namespace peristat
