// The `solver:` section of a scene (docs/guide/scene.md, "solver"): Newton, ADR, the Krylov
// and Belos options.
#include "scene/solver_section.hpp"

#include <fstream>
#include <string>

#include "scene/yaml_schema.hpp"

namespace peristat {

namespace {

using schema::Field;
using schema::Map;

/// One of an enum's values, by the name to_string() gives it.
template <class Kind>
Kind read_kind(const Field& field, std::initializer_list<Kind> kinds) {
  std::vector<std::string_view> names;
  for (Kind k : kinds) names.push_back(to_string(k));
  const std::string chosen = schema::choice(field, names);
  for (Kind k : kinds)
    if (to_string(k) == chosen) return k;
  return *kinds.begin();  // unreachable: choice() accepted one of the names
}

void read_krylov(const Field& field, SolverOptions& o) {
  const Map m = checked_map(field, {"rtol", "max_iterations", "preconditioner", "bond_radius", "factors",
                                    "contact_zone", "contact_zone_cap"});
  if (auto f = m.find("contact_zone"))
    o.bond_preconditioner.contact_zone_layers = schema::int_at_least(*f, 0);
  if (auto f = m.find("contact_zone_cap")) {
    const double cap = schema::positive(*f);
    if (cap > 1.0) schema::out_of_range(*f, "0 < contact_zone_cap <= 1 (a fraction of the particles)");
    o.bond_preconditioner.contact_zone_cap = cap;
  }
  if (auto f = m.find("rtol")) o.linear.rtol = schema::positive(*f);
  if (auto f = m.find("bond_radius")) {
    o.bond_preconditioner.bond_radius = schema::at_least(*f, 1.0);
    o.bond_preconditioner.radius_given = true;
  }
  if (auto f = m.find("max_iterations")) o.linear.max_iterations = schema::int_at_least(*f, 1);
  if (auto f = m.find("factors")) {
    o.action_factors = read_kind(*f, {ActionFactors::automatic, ActionFactors::double_precision,
                                      ActionFactors::single_precision, ActionFactors::mixed});
    o.factors_where = f->where();
  }
  if (auto f = m.find("preconditioner"))
    o.linear.preconditioner =
        read_kind(*f, {PreconditionerKind::automatic, PreconditionerKind::bond, PreconditionerKind::cholmod,
                       PreconditionerKind::ic, PreconditionerKind::diagonal, PreconditionerKind::ilut,
                       PreconditionerKind::bond_amg});
}

NewtonOptions read_newton(const Field& field) {
  const Map m = checked_map(
      field, {"rtol", "atol", "stol", "max_iterations", "line_search", "line_search_max", "tangent", "forcing"});
  NewtonOptions o;
  if (auto f = m.find("rtol")) o.rtol = schema::positive(*f);
  if (auto f = m.find("atol")) o.atol = schema::at_least(*f, 0.0);
  if (auto f = m.find("stol")) o.stol = schema::at_least(*f, 0.0);
  if (auto f = m.find("max_iterations")) o.max_iterations = schema::int_at_least(*f, 1);
  if (auto f = m.find("line_search")) o.line_search = schema::boolean(*f);
  if (auto f = m.find("line_search_max")) o.line_search_max = schema::int_at_least(*f, 0);
  if (auto f = m.find("forcing")) o.adaptive_forcing = schema::choice(*f, {"adaptive", "fixed"}) == "adaptive";
  if (auto f = m.find("tangent"))
    o.tangent = schema::choice(*f, {"consistent", "initial"}) == "initial" ? TangentKind::initial
                                                                           : TangentKind::consistent;
  return o;
}

AdrOptions read_adr(const Field& field) {
  const Map m = checked_map(field, {"rtol", "max_iterations", "on_budget", "density_factor", "report_every", "breaking"});
  AdrOptions o;
  if (auto f = m.find("rtol")) o.rtol = schema::positive(*f);
  if (auto f = m.find("max_iterations")) {
    o.max_iterations = static_cast<long>(schema::integer(*f));
    if (o.max_iterations < 1) schema::out_of_range(*f, "max_iterations >= 1");
  }
  if (auto f = m.find("on_budget")) o.accept_on_budget = schema::choice(*f, {"fail", "accept"}) == "accept";
  if (auto f = m.find("density_factor")) {
    o.density_factor = schema::positive(*f);
    if (o.density_factor < 1.0) schema::out_of_range(*f, "density_factor >= 1 (smaller is unstable)");
  }
  if (auto f = m.find("report_every")) {
    o.report_every = static_cast<long>(schema::integer(*f));
    if (o.report_every < 1) schema::out_of_range(*f, "report_every >= 1");
  }
  if (auto f = m.find("breaking")) o.break_during = schema::choice(*f, {"equilibrium", "iterations"}) == "iterations";
  return o;
}

BelosOptions read_belos(const Field& field) {
  const Map m = checked_map(field, {"method", "preconditioner", "partition", "tangent", "bonds", "model",
                                    "rtol", "max_iterations", "restart", "muelu_parameters"});
  BelosOptions o;
  if (auto f = m.find("method")) o.method = read_kind(*f, {BelosMethod::automatic, BelosMethod::cg, BelosMethod::gmres});
  if (auto f = m.find("preconditioner"))
    o.preconditioner = read_kind(*f, {BelosPreconditioner::muelu, BelosPreconditioner::ifpack2_ilut,
                                      BelosPreconditioner::ifpack2_relaxation, BelosPreconditioner::bond_factor});
  if (auto f = m.find("partition"))
    o.partition = read_kind(*f, {BelosPartition::strips, BelosPartition::rcb});
  if (auto f = m.find("tangent"))
    o.tangent = read_kind(*f, {BelosTangent::assembled, BelosTangent::matrix_free});
  // Retired keys: every rank of a run under mpirun holds its own part of the model and the
  // families around it (docs/guide/distributed.md); a scene that still names them is told so.
  for (const char* retired : {"bonds", "model"})
    if (auto f = m.find(retired))
      f->fail("is retired: under mpirun every rank holds its own part of the model, its particles and the "
              "families around them (docs/guide/distributed.md); remove the key");
  if (auto f = m.find("rtol")) o.rtol = schema::positive(*f);
  if (auto f = m.find("max_iterations")) o.max_iterations = schema::int_at_least(*f, 1);
  if (auto f = m.find("restart")) o.restart = schema::int_at_least(*f, 1);
  if (auto f = m.find("muelu_parameters")) {
    o.muelu_parameters = schema::text(*f);
    if (!std::ifstream(o.muelu_parameters)) f->fail("cannot read \"" + o.muelu_parameters + "\" (a MueLu XML parameter list)");
  }
  return o;
}

}  // namespace

SolverOptions read_solver(const Field& field) {
  const Map m = checked_map(field, {"type", "linear", "krylov", "belos", "newton", "adr"});
  SolverOptions o;
  if (auto f = m.find("type")) o.type = read_kind(*f, {SolverKind::newton, SolverKind::adr});
  if (auto f = m.find("linear"))
    o.linear.type =
        read_kind(*f, {LinearSolverKind::automatic, LinearSolverKind::cholmod, LinearSolverKind::umfpack,
                       LinearSolverKind::klu, LinearSolverKind::ldlt, LinearSolverKind::cg,
                       LinearSolverKind::bicgstab, LinearSolverKind::belos, LinearSolverKind::matrix_free});
  if (auto f = m.find("krylov")) read_krylov(*f, o);
  if (auto f = m.find("belos")) o.linear.belos = read_belos(*f);
  if (auto f = m.find("newton")) o.newton = read_newton(*f);
  if (auto f = m.find("adr")) o.adr = read_adr(*f);
  return o;
}

}  // namespace peristat
