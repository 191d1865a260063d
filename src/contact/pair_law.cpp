#include "contact/pair_law.hpp"

#include <cmath>
#include <limits>

#include "discretisation/model.hpp"

namespace peristat {

namespace {

/// Contact modulus of eq 17 (or the scene's override).
double contact_modulus(const Material& m1, const Material& m2, double override_value) {
  if (override_value > 0.0) return override_value;
  return 1.0 / ((1.0 - m1.nu * m1.nu) / m1.E + (1.0 - m2.nu * m2.nu) / m2.E);
}

}  // namespace

PairStiffness::PairStiffness(const Model& model, double modulus_override, bool exact)
    : m_model(model), m_delta3(std::pow(model.horizon, 3)), m_modulus_override(modulus_override), m_exact(exact) {}

double PairStiffness::with_modulus(Index i, Index j, double modulus_override) const {
  const Particles& p = m_model.particles;
  const Material &mi = m_model.bodies[p.body[i]].material, &mj = m_model.bodies[p.body[j]].material;
  const double thickness = 0.5 * (mi.thickness + mj.thickness);
  return 3.0 * contact_modulus(mi, mj, modulus_override) * p.volume[i] * p.volume[j] / (m_delta3 * thickness);
}

double PairStiffness::operator()(Index i, Index j) const {
  // Exact enforcement: C is the eq 17 pair stiffness, which sets the stick penalty k_t;
  // contact.stiffness only sets where the augmentation starts (initial_boost), so that it
  // changes the rate of the multiplier iteration and not the answer.
  return with_modulus(i, j, m_exact ? 0.0 : m_modulus_override);
}

Mat2 closed_pair_block(const ContactPair& pair, double normal_scale, double stick_scale, bool stick) {
  const double kn = pair.stiffness / pair.gap0;
  Mat2 S = (normal_scale * kn) * pair.normal * pair.normal.transpose();
  if (stick) {
    const Vec2 t = pair.tangent();
    S += (stick_scale * kn) * t * t.transpose();
  }
  return S;
}

void close_if_touching(const ContactPair& pair, const Vec2& X, const Vec2& du, double boost, const ContactLaw& law,
                       PairResult& out) {
  const Vec2 Y = X + du;
  const double yn = pair.normal.dot(Y), s = 1.0 - yn / pair.gap0;
  const bool stick = law.friction > 0.0;
  if (law.exact) {
    if (pair.gap0 > law.window * (1.0 + kLatticeRoundOff) || std::abs(pair.tangent().dot(Y)) >= law.window ||
        s < -kLatticeRoundOff)
      return;
    out.J = closed_pair_block(pair, boost, law.stick_scale(boost), stick);
  } else if (law.normal == NormalLaw::paper) {
    if (yn <= 0.0 || Y.norm() > law.radius * (1.0 + kLatticeRoundOff) || s < -kLatticeRoundOff) return;
    out.J = closed_pair_block(pair, 1.0, law.tangential_factor, stick);
  } else {  // pair law: the normal term acts along the current pair direction
    const double r = Y.norm();
    if (r > law.radius * (1.0 + kLatticeRoundOff) || r <= std::numeric_limits<double>::min()) return;
    const Vec2 e = Y / r;
    out.J = (pair.stiffness / law.radius) * e * e.transpose() +
            closed_pair_block(pair, 0.0, law.tangential_factor, stick);
  }
  out.status = stick ? PairStatus::stick : PairStatus::slip;  // frictionless closed pairs slide freely
}

namespace {

/// The normal force F >= 0 of a pair, its gradient dF/dY, its direction on j and its
/// Jacobian dg/dY; F = 0 when the pair carries none.
struct NormalForce {
  double F = 0.0;
  Vec2 dF = Vec2::Zero();
  Vec2 along = Vec2::Zero();  ///< direction of the normal force on j
  Mat2 Jn = Mat2::Zero();
};

NormalForce exact_normal(const ContactPair& pair, const Vec2& Y, const PairHistory& history, const ContactLaw& law,
                         bool want_jacobian) {
  // Augmented Lagrangian along n (section 8): F = phi(|t.Y|) max(0, lambda + C s), for a
  // pair whose cells face each other. No distance gate: a pair that has crossed (n.Y < 0,
  // s > 1) is pushed back harder.
  NormalForce f;
  const Vec2& n = pair.normal;
  const double a = pair.gap0, C = pair.stiffness;
  if (a > law.window * (1.0 + kLatticeRoundOff)) return f;
  const Vec2 t = pair.tangent();
  const double yt = t.dot(Y), offset = std::abs(yt);
  if (offset >= law.window) return f;
  const double s = 1.0 - n.dot(Y) / a + history.strain;
  const double Ca = history.boost * C;  // the pair's augmentation stiffness
  const double q = history.multiplier + Ca * s;
  if (q <= 0.0) return f;
  double slope = 0.0;
  const double phi = window_weight(offset, law, &slope);
  const Vec2 dphi = (yt > 0.0 ? slope : -slope) * t;
  f.F = phi * q;
  f.dF = -(phi * Ca / a) * n + q * dphi;
  f.along = n;
  if (want_jacobian) f.Jn = -n * f.dF.transpose();
  return f;
}

NormalForce paper_normal(const ContactPair& pair, const Vec2& Y, const ContactLaw& law, bool want_jacobian) {
  // Eq 16: stretch of the virtual bond along the interface normal, compression positive.
  // The gate distance is |Y| while the particles have not passed each other (the paper's
  // rule) and |t.Y| once they have (n.Y < 0), so that a crossed pair is pushed back, not
  // released (section 2).
  NormalForce f;
  const Vec2& n = pair.normal;
  const double a = pair.gap0, C = pair.stiffness;
  const double yn = n.dot(Y);
  const bool has_crossed = yn < 0.0;
  const double r = has_crossed ? std::abs(pair.tangent().dot(Y)) : Y.norm();
  const double rc = law.radius;
  if (r >= rc) return f;
  const double s = 1.0 - yn / a;
  if (s <= 0.0) return f;
  // Switch-on ramp h(r): 0 at delta_c, 1 from (1 - gate) delta_c inwards.
  double h = 1.0;
  Vec2 dh = Vec2::Zero();
  if (law.gate > 0.0) {
    const double width = law.gate * rc, rho = (rc - r) / width;
    if (rho < 1.0) {
      h = rho;
      if (has_crossed) {
        const Vec2 t = pair.tangent();
        dh = -(t.dot(Y) > 0.0 ? 1.0 : -1.0) / width * t;
      } else {
        dh = -Y / (r * width);
      }
    }
  }
  f.F = C * s * h;
  f.dF = C * (-h / a * n + s * dh);
  f.along = n;
  if (want_jacobian) f.Jn = -n * f.dF.transpose();
  return f;
}

NormalForce pair_law_normal(const ContactPair& pair, const Vec2& Y, const ContactLaw& law, bool want_jacobian) {
  // Pair law: along the current pair direction, zero at delta_c.
  NormalForce f;
  const double C = pair.stiffness;
  const double r = Y.norm();
  const double rc = law.radius;
  if (r >= rc) return f;
  if (r <= std::numeric_limits<double>::min()) return f;
  const Vec2 e = Y / r;
  f.F = C * (rc - r) / rc;
  f.dF = -C / rc * e;
  f.along = e;
  if (want_jacobian) f.Jn = (C / rc) * e * e.transpose() - (f.F / r) * (Mat2::Identity() - e * e.transpose());
  return f;
}

/// Coulomb friction along t of a pair carrying the normal force F with gradient dF: its
/// status, tangential force and their share of g and J.
void add_friction(const ContactPair& pair, const Vec2& du, double F, const Vec2& dF, const PairHistory& history,
                  const ContactLaw& law, bool want_jacobian, PairResult& out) {
  out.status = PairStatus::slip;  // frictionless pairs slide freely
  if (law.friction > 0.0 && law.velocity_sign) {
    // Eq 13: f_c F_n opposing the relative tangential velocity; none while it is zero.
    const Vec2 t = pair.tangent();
    const double v = history.tangential_velocity;
    const double sign = v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
    out.status = sign == 0.0 ? PairStatus::stick : PairStatus::slip;
    out.tangential = sign * law.friction * F;
    if (want_jacobian) out.J += (sign * law.friction) * t * dF.transpose();
    out.g += out.tangential * t;
  } else if (law.friction > 0.0) {
    // A return map on w - w_p (eq 14); under exact stick the trial adds the multiplier mu, or
    // +-f_c F for a pair that slid at its last update (limit_sign).
    const Vec2 t = pair.tangent();
    const double kt = law.stick_scale(history.boost) * pair.stiffness / pair.gap0;
    const bool at_limit = history.limit_sign != 0.0;
    const double base = at_limit ? history.limit_sign * law.friction * F : history.tangential_multiplier;
    const double trial = base + kt * (t.dot(du) - history.slip);
    const double limit = law.friction * F;
    if (std::abs(trial) <= limit) {
      out.status = PairStatus::stick;
      out.tangential = trial;
      if (want_jacobian) {
        out.J += kt * t * t.transpose();
        if (at_limit) out.J += (history.limit_sign * law.friction) * t * dF.transpose();
      }
    } else {
      const double sign = trial > 0.0 ? 1.0 : -1.0;
      out.tangential = sign * limit;
      if (want_jacobian) out.J += (sign * law.friction) * t * dF.transpose();
    }
    out.g += out.tangential * t;
  }
}

}  // namespace

PairResult contact_pair(const ContactPair& pair, const Vec2& X, const Vec2& du, const PairHistory& history,
                        const ContactLaw& law, bool want_jacobian) {
  PairResult out;
  const Vec2 Y = X + du;
  // Normal force F >= 0 and its gradient dF/dY.
  const NormalForce f = law.exact                       ? exact_normal(pair, Y, history, law, want_jacobian)
                        : law.normal == NormalLaw::paper ? paper_normal(pair, Y, law, want_jacobian)
                                                         : pair_law_normal(pair, Y, law, want_jacobian);
  if (f.F <= 0.0) return out;
  out.normal_force = f.F;
  out.g = -f.F * f.along;
  if (want_jacobian) out.J = f.Jn;
  // Coulomb friction along t by a return map on w - w_p (eq 14), or eq 13.
  add_friction(pair, du, f.F, f.dF, history, law, want_jacobian, out);
  return out;
}

}  // namespace peristat
