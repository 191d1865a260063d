#include "app/preflight.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>

#include "app/setup.hpp"
#include "assembly/pattern.hpp"
#include "core/error.hpp"
#include "core/geometry.hpp"
#include "discretisation/model.hpp"
#include "parallel/mpi/session.hpp"

namespace peristat {

namespace {

/// ", per rank of the N on it" when ranks share the machine, else "".
std::string sharing(const SizeEstimate& e) {
  return e.sharing_ranks > 1 ? " per rank of the " + std::to_string(e.sharing_ranks) +
                                   " on it (each holds the whole model and its own rows of the tangent)"
                             : std::string();
}

/// MemAvailable of /proc/meminfo [bytes]; 0 when it cannot be read (not Linux).
double available_memory() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kib = 0.0;
  std::string unit;
  while (in >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib * 1024.0;
  return 0.0;
}

std::string format_bytes(double b) {
  char buf[64];
  if (b >= 1e12)
    std::snprintf(buf, sizeof buf, "%.3g TB", b / 1e12);
  else if (b >= 1e9)
    std::snprintf(buf, sizeof buf, "%.3g GB", b / 1e9);
  else
    std::snprintf(buf, sizeof buf, "%.3g MB", b / 1e6);
  return buf;
}

const Body* find_body(const Scene& scene, const std::string& name) {
  for (const Body& b : scene.bodies)
    if (b.name == name) return &b;
  return nullptr;
}

}  // namespace

/// The bond preconditioner's nonzeros per tangent nonzero (m = 3: 0.143, 0.138, 0.136 at
/// 2,500, 10,000, 40,000 particles).
constexpr double kBondNonzeroShare = 0.14;

SizeEstimate estimate_model(const Scene& scene) {
  SizeEstimate e;
  const double dx = scene.discretization.spacing, m = scene.discretization.horizon_factor;
  const double pi = std::numbers::pi;
  for (const Body& b : scene.bodies) e.particles += std::abs(geometry::signed_area(b.shape.vertices)) / (dx * dx);
  for (const BoundaryCondition& bc : scene.boundary) {
    const Body* body = find_body(scene, bc.body);
    if (!body) continue;
    const auto& v = body->shape.vertices;
    const double layers = bc.mirror ? mirror_layers(m) : bc.layers;
    if (bc.selector == BoundaryCondition::Selector::edge && bc.edge >= 0) {
      const Vec2 a = v[static_cast<std::size_t>(bc.edge)], c = v[(static_cast<std::size_t>(bc.edge) + 1) % v.size()];
      e.fictitious += ((a - c).norm() / dx + 2.0 * layers) * layers;
    } else if (bc.selector == BoundaryCondition::Selector::surround) {
      double perimeter = 0.0;
      for (std::size_t k = 0; k < v.size(); ++k) perimeter += (v[(k + 1) % v.size()] - v[k]).norm();
      e.fictitious += (perimeter / dx + 4.0 * layers) * layers;
    }
  }
  // The stencil itself when it is cheap to build (a (2m + 2)^2 loop), else its area.
  e.family = m <= 64.0 ? static_cast<double>(make_stencil(m, 1.0, scene.discretization.quadrature).offset.size())
                       : pi * (m + 0.5) * (m + 0.5);
  // The OSB tangent couples a particle with every particle within two horizons (a
  // neighbour's neighbours): 2 x 2 entries per pair.
  const double coupled = pi * (2.0 * m + 0.5) * (2.0 * m + 0.5);
  e.nonzeros = 4.0 * (e.particles + e.fictitious) * coupled;
  e.memory_bytes = kBytesPerNonzero * e.nonzeros;
  return e;
}

namespace {

/// Belos on its matrix-free tangent (solver.belos.tangent: matrix_free) applies the tangent
/// like matrix_free and assembles the bond matrix only (its copy in Tpetra is what MueLu,
/// Ifpack2 or the factor work on).
void price_belos_bond_matrix(const BelosOptions& belos, double n, SizeEstimate& e) {
  const double nnz = kBondNonzeroShare * e.nonzeros;  // the default bond radius
  if (belos.preconditioner == BelosPreconditioner::bond_factor) {
    e.factor_of = "the bond preconditioner, with its copy in Tpetra";
    e.factor_nonzeros = factor_fill(n, true) * nnz;
    e.factor_bytes = kBytesPerFactorNonzero * e.factor_nonzeros + 2.0 * kBytesPerCopiedNonzero * nnz;
  } else if (belos.preconditioner == BelosPreconditioner::muelu) {
    e.factor_of = "the bond matrix, its copy in Tpetra and MueLu's hierarchy";
    e.factor_bytes = kBytesPerAmgNonzero * nnz;
  } else {
    e.factor_of = "the bond matrix and its copy in Tpetra (Ifpack2's own storage not estimated)";
    e.factor_bytes = 2.0 * kBytesPerCopiedNonzero * nnz;
  }
}

/// The contact zone GMRES solves exactly after the V-cycle (assembly/contact_zone.hpp), with
/// friction (GMRES) and solver.krylov.contact_zone > 0, at its largest: contact_zone_cap of
/// the particles, `nnz` the whole bond matrix's nonzeros. Its rows are held four times (the
/// problem's, the solver's, ZoneCorrection's by rows and its block) besides the factor.
void price_contact_zone(const Scene& scene, const RunPlan& plan, double n, double nnz, SizeEstimate& e) {
  const BondPreconditionerOptions& o = plan.bond_preconditioner;
  if (!scene.contact.enabled || scene.contact.friction <= 0.0 || o.contact_zone_layers == 0) return;
  const double zone_nnz = o.contact_zone_cap * nnz;
  e.factor_of += " and the contact zone's factor";
  e.factor_bytes += kBytesPerFactorNonzero * factor_fill(o.contact_zone_cap * n, true) * zone_nnz +
                    4.0 * kBytesPerCopiedNonzero * zone_nnz;
}

/// The bond preconditioner of cg, matrix_free or belos: its factor, or its MueLu V-cycle
/// (bond_amg) and the contact zone's factor.
void price_bond_preconditioner(const Scene& scene, const RunPlan& plan, double n, SizeEstimate& e) {
  // kBondNonzeroShare is for the default radius (20 lattice neighbours); another radius
  // scales it by its own neighbour count (1.42 dx: 8).
  const double radius = plan.bond_preconditioner.bond_radius;
  const double r2 = radius * radius;
  const int reach = static_cast<int>(std::floor(radius));
  int neighbours = 0;
  for (int i = -reach; i <= reach; ++i)
    for (int j = -reach; j <= reach; ++j)
      if ((i != 0 || j != 0) && i * i + j * j <= r2 * (1.0 + kBondRadiusMargin)) ++neighbours;
  const double nnz = kBondNonzeroShare * e.nonzeros * (1.0 + neighbours) / 21.0;
  if (plan.preconditioner == PreconditionerKind::bond_amg) {
    e.factor_of = "the bond matrix, its copy in Tpetra and MueLu's hierarchy";
    e.factor_bytes = kBytesPerAmgNonzero * nnz;
    e.factor_bytes += kBytesPerBlockedNonzero * nnz;  // (the copy's CSR values go then: not counted)
    price_contact_zone(scene, plan, n, nnz, e);
  } else {
    e.factor_of = "the bond preconditioner";
    e.factor_nonzeros = factor_fill(n, true) * nnz;
    e.factor_bytes = kBytesPerFactorNonzero * e.factor_nonzeros + kBytesPerCopiedNonzero * nnz;
  }
}

/// The factorisation Newton's linear solver makes: the tangent's (direct solvers, cg with the
/// cholmod preconditioner) or the bond preconditioner's (cg's default); LU (UMFPACK, KLU) holds
/// L and U, twice a Cholesky factor; the incomplete or diagonal preconditioners none to speak of.
void price_factorisation(const Scene& scene, const RunPlan& plan, double n, SizeEstimate& e) {
  const LinearSolverKind kind = plan.linear;
  const bool cg = kind == LinearSolverKind::cg || kind == LinearSolverKind::matrix_free;
  const bool belos = kind == LinearSolverKind::belos;
  const PreconditionerKind pc = plan.preconditioner;
  if (belos && plan.matrix_free()) {
    price_belos_bond_matrix(scene.solver.linear.belos, n, e);
  } else if (belos && scene.solver.linear.belos.preconditioner != BelosPreconditioner::bond_factor) {
    // MueLu's hierarchy and Ifpack2's incomplete factors are not estimated; the tangent's
    // copy in Tpetra is (added by share_over_ranks()).
    e.factor_of = "the tangent's copy in Tpetra (the preconditioner's own storage not estimated)";
  } else if ((cg || belos) && (pc == PreconditionerKind::bond || pc == PreconditionerKind::bond_amg)) {
    price_bond_preconditioner(scene, plan, n, e);
  } else if ((!cg && !belos && kind != LinearSolverKind::bicgstab) || (cg && pc == PreconditionerKind::cholmod)) {
    e.factor_of = "the tangent";
    const double lu = kind == LinearSolverKind::umfpack || kind == LinearSolverKind::klu ? 2.0 : 1.0;
    e.factor_nonzeros = lu * factor_fill(n, false) * e.nonzeros;
    e.factor_bytes = kBytesPerFactorNonzero * e.factor_nonzeros + kBytesPerCopiedNonzero * e.nonzeros;
  }
}

/// Belos's share per rank, and its copy of the tangent.
void share_over_ranks(const Scene& scene, const RunPlan& plan, double n, SizeEstimate& e) {
  if (plan.linear != LinearSolverKind::belos) return;
  const int ranks = plan.ranks;
  if (!plan.matrix_free()) {
    e.factor_bytes += kBytesPerCopiedNonzero * e.nonzeros;  // the tangent's copy in Tpetra
    if (scene.solver.linear.belos.preconditioner == BelosPreconditioner::bond_factor)
      e.factor_of = "the bond preconditioner, with the tangent's copy in Tpetra";
  }
  if (ranks <= 1) return;
  // Under mpirun every rank holds its share of the matrices, and its part of the model: the
  // families of its particles and of the rings around them, (m + 1) spacings deep each: about
  // 1/P + 4 r (m + 1) / sqrt(N P) of them for square parts with r rings (measured 0.513 at
  // 1000 x 1000 on two ranks with one ring: 1/2 + 0.011 and the fictitious layers).
  const double m = scene.discretization.horizon_factor;
  e.factor_bytes /= ranks;
  e.factor_nonzeros /= ranks;
  e.memory_bytes *= std::min(1.0, 1.0 / ranks + 4.0 * plan.model.rings * (m + 1.0) / std::sqrt(n * ranks));
}

}  // namespace

SizeEstimate estimate_size(const Scene& scene, const RunPlan& plan) {
  SizeEstimate e = estimate_model(scene);
  if (plan.newton()) {
    const double n = e.particles + e.fictitious;
    // No tangent and no pattern: the model and the families' tangent data only.
    if (plan.matrix_free())
      e.memory_bytes =
          matrix_free_bytes_per_nonzero(scene.failure.enabled, plan.float_factors, plan.float_copy) *
          e.nonzeros;
    price_factorisation(scene, plan, n, e);
    share_over_ranks(scene, plan, n, e);
  }
  // Under mpirun the ranks on this machine share its memory (docs/guide/distributed.md).
  e.sharing_ranks = parallel::ranks_on_this_machine();
  e.available_bytes = available_memory() / e.sharing_ranks;
  return e;
}

SizeEstimate estimate_size(const Scene& scene) { return estimate_size(scene, make_run_plan(scene, 1)); }

double factor_fill(double particles, bool bond_preconditioner) {
  const double log_n = std::log2(std::max(particles, 2.0));
  return std::max(1.0, bond_preconditioner ? 0.51 * log_n - 2.0 : 0.59 * log_n - 4.7);
}

namespace {

/// Refuses (InputError) a model, or its factorisation, that the machine's memory cannot hold.
void check_memory(const Scene& scene, const RunPlan& plan, const SizeEstimate& e) {
  const Discretization& d = scene.discretization;
  char buf[640];
  if (e.available_bytes > 0.0 && e.memory_bytes <= e.available_bytes &&
      e.memory_bytes + e.factor_bytes > e.available_bytes) {
    std::snprintf(buf, sizeof buf,
                  "the model needs about %s and the factorisation of %s about %s more (%.3g factor nonzeros, "
                  "estimated), and the machine has %s available%s: refused before allocating; use a coarser spacing%s",
                  format_bytes(e.memory_bytes).c_str(), e.factor_of.c_str(), format_bytes(e.factor_bytes).c_str(),
                  e.factor_nonzeros, format_bytes(e.available_bytes).c_str(), sharing(e).c_str(),
                  e.factor_of == "the tangent" ? " or solver.linear=cg (its bond preconditioner factorises a "
                                                 "matrix of about a seventh of the tangent's nonzeros)"
                                               : "");
    throw InputError(d.spacing_where, buf);
  }
  if (e.available_bytes > 0.0 && e.memory_bytes > e.available_bytes) {
    // Without an assembled tangent the model may fit: say so, with its size.
    const double free_bytes = matrix_free_bytes_per_nonzero(scene.failure.enabled) * e.nonzeros;
    const std::string hint =
        !plan.matrix_free() && plan.newton() && free_bytes < e.available_bytes
            ? std::string(plan.linear == LinearSolverKind::belos ? " or solver.belos.tangent=matrix_free"
                                                                 : " or solver.linear=matrix_free") +
                  " (no assembled tangent: about " + format_bytes(free_bytes) +
                  " before the bond preconditioner's factor)"
            : "";
    std::snprintf(buf, sizeof buf,
                  "the model needs about %s (%.3g particles, %.3g tangent nonzeros at %.1f B each, before any "
                  "factorisation) and the machine has %s available%s: refused before allocating; use a coarser "
                  "spacing%s",
                  format_bytes(e.memory_bytes).c_str(), e.particles + e.fictitious, e.nonzeros,
                  e.memory_bytes / std::max(e.nonzeros, 1.0), format_bytes(e.available_bytes).c_str(),
                  sharing(e).c_str(), hint.c_str());
    throw InputError(d.spacing_where, buf);
  }
}

/// Exact contact with a failure criterion and a closure tolerance the scene gives above
/// kClosureToleranceWarnOverStretch x s_c (a tolerance not given is kept at half that,
/// resolve_closure_tolerance()): a pair may stay closed by up to contact.closure_tolerance of
/// its distance, about one spacing, and where that is not small against the critical stretch
/// s_c, the bonds at a closed crack's tip feel the tolerance, not the continuum. Measured on
/// cases/lefm_inclined_crack at dx = 10 mm, f_c = 0.4 (s_c = 6.8e-4): the skew criterion's
/// start load is 6.4 % low at tolerance 1e-3 against 1e-5, 1.3 % at 1e-4; the displacement
/// fields of cases 4.1 and 4.3 move by 1e-5 only. Empty when fine.
std::string closure_tolerance_warning(const Scene& scene) {
  const ContactOptions& c = scene.contact;
  if (!scene.failure.enabled || !c.enabled || c.enforcement != ContactEnforcement::exact ||
      !c.closure_tolerance_given)
    return {};
  const double s_c = smallest_critical_stretch(scene);
  if (!(c.closure_tolerance > kClosureToleranceWarnOverStretch * s_c)) return {};
  char buf[512];
  std::snprintf(
      buf, sizeof buf,
      "contact.closure_tolerance %g is above %g of the critical stretch %.3g: a closed crack's faces may "
      "overlap by more than its bonds stretch before they break, and the failure criterion near them "
      "feels the tolerance (a crack start measured 6%% low at 1.5 s_c); leave it out, or "
      "contact.closure_tolerance=%.2g, to take it out",
      c.closure_tolerance, kClosureToleranceWarnOverStretch, s_c, kClosureToleranceOverStretch * s_c);
  return buf;
}

}  // namespace

std::vector<std::string> preflight(const Scene& scene, const RunPlan& plan, const SizeEstimate& e) {
  const Discretization& d = scene.discretization;
  const double delta = d.horizon_factor * d.spacing;
  char buf[640];
  if (e.family > kMaxFamily) {
    std::snprintf(buf, sizeof buf,
                  "horizon_factor %g gives about %.3g bonds per family; at most %.0f are accepted (horizon_factor "
                  "up to about 24): the tangent would couple each particle with about %.3g others",
                  d.horizon_factor, e.family, kMaxFamily,
                  std::numbers::pi * (2.0 * d.horizon_factor + 0.5) * (2.0 * d.horizon_factor + 0.5));
    throw InputError(d.horizon_where, buf);
  }
  for (const Body& b : scene.bodies) {
    Vec2 lo = b.shape.vertices.front(), hi = lo;
    for (const Vec2& v : b.shape.vertices) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    const double longest = (hi - lo).maxCoeff();
    if (delta > longest) {
      std::snprintf(buf, sizeof buf,
                    "the horizon %g m (horizon_factor %g x spacing %g m) is longer than body '%s' (%g m at its "
                    "longest): every family would span the body, which is then no continuum; refine the spacing "
                    "or lower horizon_factor",
                    delta, d.horizon_factor, d.spacing, b.name.c_str(), longest);
      // Blame the spacing when the body is not even two spacings long, else the factor.
      throw InputError(d.spacing * 2.0 > longest ? d.spacing_where : d.horizon_where, buf);
    }
  }
  if ((scene.solver.action_factors == ActionFactors::single_precision ||
       scene.solver.action_factors == ActionFactors::mixed) &&
      !plan.matrix_free()) {
    const std::string why = plan.newton() ? "solver.linear " + std::string(to_string(plan.linear)) : "ADR";
    std::snprintf(
        buf, sizeof buf,
        "%s keeps the matrix-free action's factors (or a copy of them) in single precision, but this run "
        "assembles its "
        "tangent (%s); set solver.linear=matrix_free, or remove the key",
        std::string(to_string(scene.solver.action_factors)).c_str(), why.c_str());
    throw InputError(scene.solver.factors_where, buf);
  }
  check_memory(scene, plan, e);
  std::vector<std::string> warnings;
  if (d.horizon_factor < 2.0) {
    std::snprintf(buf, sizeof buf,
                  "%s: horizon_factor %g < 2, families of about %.0f bonds. Uniform fields stay exact and a "
                  "crack's slip within 3%% of LEFM, but the failure criteria, calibrated for a continuum family, "
                  "start a mode I crack at about 1.8 K_Ic at m = 1 and 1.4 at m = 1.5 (1.2 at m = 2, 1.0 at "
                  "m = 3; verification.KField)",
                  d.horizon_where.describe().c_str(), d.horizon_factor, e.family);
    warnings.emplace_back(buf);
  }
  if (const std::string w = closure_tolerance_warning(scene); !w.empty()) warnings.push_back(w);
  if (scene.failure.enabled && scene.solver.adr.break_during && plan.newton())
    warnings.emplace_back(
        "solver.adr.breaking: iterations applies to ADR (--solver adr); this run uses Newton, which breaks bonds "
        "between converged equilibria");
  return warnings;
}

}  // namespace peristat
