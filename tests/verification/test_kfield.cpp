// The failure criteria on the exact near-tip field of linear elastic fracture mechanics
// (issue 14, docs/theory/failure.md "The skew of shallow bonds"). The K-field of a
// semi-infinite crack is sampled at the particles of a unit lattice (dx = 1, horizon
// m = 3), the bonds the crack cuts are removed as the discretisation removes them, and the
// criterion of every intact bond near the tip is evaluated at K = K_c = sqrt(E G_c). The
// start K of the criterion is K_c / (largest ratio). The field is u ~ K sqrt(r), and both
// critical values scale as sqrt(G_c / delta), so the start K / K_c depends only on m, the
// crack's angle to the lattice and where the tip sits in its cell, not on dx or G_c: this
// is the criterion's own agreement with LEFM, without the PD solution's tip blunting or the
// finite crack's remote field.
//
// Sampled: the crack along 0, -30, -45 and -60 degrees (the angles of the LEFM case and of
// case 4.4), the tip at nine places in a cell. Measured (2026-11-24):
//   mode I,  critical stretch:                        0.72-1.20, mean 0.92-1.02 per angle
//   mode II, critical skew, floor at 45 deg (default): 0.72-1.23, mean 0.94-1.03 per angle
//   mode II, critical skew, paper's eq 22:             0.27-0.76, mean 0.32-0.71 per angle
// The mode I stretch is the yardstick: the PD solution of a mode I crack starts at 1.03-1.04 x
// Griffith (verification.Failure.ModeIStartLoadAgainstGriffith). The skew with the floor
// must agree with LEFM as well as that (every start within [0.7, 1.3] K_c, the mean per
// angle within 10%), and the paper's eq 22 is kept as the reason for the floor: it starts
// a crack at 45 degrees to the lattice below 0.6 K_c wherever the tip sits.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "discretisation/model.hpp"
#include "materials/failure.hpp"

namespace peristat {
namespace {

constexpr double kE = 1.0, kNu = 0.3, kGc = 1.0, kM = 3.0;
const double kMu = kE / (2.0 * (1.0 + kNu));
const double kKappaPlaneStress = (3.0 - kNu) / (1.0 + kNu);  // Kolosov's constant
const double kBulk2d = kE / (2.0 * (1.0 - kNu));

enum class Mode { I, II };
enum class Criterion { stretch, skew };

/// Near-tip displacement (Williams): crack along -t behind the tip, r, phi polar about it.
Vec2 k_field(const Vec2& x, const Vec2& tip, const Vec2& t, Mode mode, double K) {
  const Vec2 n(-t.y(), t.x());
  const Vec2 d = x - tip;
  const double a = d.dot(t), b = d.dot(n);
  const double r = std::hypot(a, b), phi = std::atan2(b, a);
  const double f = K / (2.0 * kMu) * std::sqrt(r / (2.0 * std::numbers::pi));
  const double c = std::cos(phi / 2), s = std::sin(phi / 2), k = kKappaPlaneStress;
  double ut = 0.0, un = 0.0;
  if (mode == Mode::I) {
    ut = f * c * (k - 1.0 + 2.0 * s * s);
    un = f * s * (k + 1.0 - 2.0 * c * c);
  } else {
    ut = f * s * (k + 1.0 + 2.0 * c * c);
    un = -f * c * (k - 1.0 - 2.0 * s * s);
  }
  return ut * t + un * n;
}

/// The largest criterion ratio over the intact bonds of the particles within two horizons
/// of the tip, at K = K_c.
double peak_ratio(Mode mode, Criterion criterion, double angle_deg, const Vec2& tip, double min_sin,
                  double m = kM) {
  const Stencil st = make_stencil(m, 1.0, Quadrature::isotropic);
  const double delta = m;
  const double critical = criterion == Criterion::skew ? critical_skew(kGc, kMu, delta)
                                                       : critical_stretch(kGc, kBulk2d, kMu, delta);
  const double angle = angle_deg * std::numbers::pi / 180.0;
  const Vec2 t(std::cos(angle), std::sin(angle));
  const Vec2 crack_start = tip - 100.0 * t;  // far behind the tip: a semi-infinite crack
  const double Kc = std::sqrt(kE * kGc);
  double peak = 0.0;
  std::vector<Vec2> xi, eta;
  std::vector<double> value;
  for (int i = -10; i <= 10; ++i) {
    for (int j = -10; j <= 10; ++j) {
      const Vec2 x(i, j);
      if ((x - tip).norm() > 2.0 * delta) continue;
      xi.clear();
      eta.clear();
      const Vec2 u = k_field(x, tip, t, mode, Kc);
      for (const auto& o : st.offset) {
        const Vec2 y(i + o[0], j + o[1]);
        if (bond_crosses_crack(x, y, crack_start, tip)) continue;
        xi.push_back(y - x);
        eta.push_back(k_field(y, tip, t, mode, Kc) - u);
      }
      value.assign(xi.size(), 0.0);
      if (criterion == Criterion::skew) {
        bond_skews(xi, eta, reference_bond(xi, t), min_sin, value);
      } else {
        for (std::size_t b = 0; b < xi.size(); ++b) value[b] = bond_stretch(xi[b], eta[b]);
      }
      peak = std::max(peak, *std::max_element(value.begin(), value.end()) / critical);
    }
  }
  return peak;
}

struct Spread {
  double min = 1e300, max = 0.0, mean = 0.0;
};

/// Start K / K_c at the nine tip positions of a cell, for one crack angle.
Spread start_k(Mode mode, Criterion criterion, double angle_deg, double min_sin, double m = kM) {
  Spread s;
  int n = 0;
  for (double tx : {0.0, 0.25, 0.5}) {
    for (double ty : {0.0, 0.25, 0.5}) {
      // Off every lattice line: a tip on a particle or a crack through particle centres
      // would leave the face of a particle to round-off.
      const double k = 1.0 / peak_ratio(mode, criterion, angle_deg, Vec2(tx + 0.13, ty + 0.07), min_sin, m);
      s.min = std::min(s.min, k);
      s.max = std::max(s.max, k);
      s.mean += k;
      ++n;
    }
  }
  s.mean /= n;
  return s;
}

const double kAngles[] = {0.0, -30.0, -45.0, -60.0};

TEST(KField, ModeOneStretchStartsAtGriffith) {
  for (double a : kAngles) {
    const Spread s = start_k(Mode::I, Criterion::stretch, a, 0.0);
    std::printf("mode I stretch, crack at %4.0f deg: start K/Kc %.3f-%.3f, mean %.3f\n", a, s.min, s.max, s.mean);
    EXPECT_GE(s.min, 0.7) << a;
    EXPECT_LE(s.max, 1.3) << a;
    EXPECT_NEAR(s.mean, 1.0, 0.1) << a;
  }
}

TEST(KField, ModeTwoSkewWithTheFloorStartsAtLefm) {
  for (double a : kAngles) {
    const Spread s = start_k(Mode::II, Criterion::skew, a, std::sin(std::numbers::pi / 4));
    std::printf("mode II skew (floor 45 deg), crack at %4.0f deg: start K/Kc %.3f-%.3f, mean %.3f\n", a, s.min,
                s.max, s.mean);
    EXPECT_GE(s.min, 0.7) << a;
    EXPECT_LE(s.max, 1.3) << a;
    EXPECT_NEAR(s.mean, 1.0, 0.1) << a;
  }
}

TEST(KField, PaperSkewStartsEarlyOnShallowBonds) {
  for (double a : kAngles) {
    const Spread s = start_k(Mode::II, Criterion::skew, a, 0.0);
    std::printf("mode II skew (eq 22), crack at %4.0f deg: start K/Kc %.3f-%.3f, mean %.3f\n", a, s.min, s.max,
                s.mean);
    EXPECT_LT(s.max, 0.8) << a;  // early at every angle
    if (a != 0.0) {
      EXPECT_LT(s.max, 0.6) << a;  // the diagonal angles: below 0.6 wherever the tip sits
    }
  }
}

// What a small horizon costs (the warning of src/app/preflight.cpp for horizon_factor < 2):
// the criteria are calibrated for a continuum family, and on a family of a few bonds the
// critical stretch starts a mode I crack late. Measured (means over the nine tip positions,
// crack along 0 / -45 degrees): 1.81 / 1.69 at m = 1, 1.48 / 1.38 at m = 1.5, 1.25 / 1.17 at
// m = 2, 1.02 / 0.95 at m = 3. Asserted: late by more than 50% at m = 1 and by 20-60% at
// m = 1.5, so that the warning's figures stay true.
TEST(KField, SmallHorizonsStartModeOneLate) {
  for (double a : {0.0, -45.0}) {
    const Spread m1 = start_k(Mode::I, Criterion::stretch, a, 0.0, 1.0);
    const Spread m15 = start_k(Mode::I, Criterion::stretch, a, 0.0, 1.5);
    std::printf("mode I stretch, crack at %4.0f deg: mean start K/Kc %.3f at m = 1, %.3f at m = 1.5\n", a, m1.mean,
                m15.mean);
    EXPECT_GT(m1.mean, 1.5) << a;
    EXPECT_GT(m15.mean, 1.2) << a;
    EXPECT_LT(m15.mean, 1.6) << a;
  }
}

}  // namespace
}  // namespace peristat
