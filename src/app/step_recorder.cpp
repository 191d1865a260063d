#include "app/step_recorder.hpp"

#include <cstdio>

#include <nlohmann/json.hpp>

#include "app/interrupt.hpp"
#include "core/huge_pages.hpp"

namespace peristat {

namespace {

/// The resolved options and model size, stored under "run" in summary.json.
std::string run_info_json(const Scene& scene, const ModelSize& s, const std::string& linear, int threads,
                          const std::vector<std::string>& checks) {
  const NewtonOptions& n = scene.solver.newton;
  nlohmann::ordered_json solver = {{"type", to_string(scene.solver.type)}};
  if (scene.solver.type == SolverKind::adr) {
    const AdrOptions& a = scene.solver.adr;
    solver["adr_rtol"] = a.rtol;
    solver["adr_max_iterations"] = static_cast<double>(a.max_iterations);  // a double, as always written
    solver["adr_on_budget"] = a.accept_on_budget ? "accept" : "fail";
    solver["adr_density_factor"] = a.density_factor;
  } else {
    solver["linear"] = linear;
    if (!scene.solver.linear.auto_choice.empty()) solver["linear_auto"] = scene.solver.linear.auto_choice;
    solver["action_factors"] =
        to_string(scene.solver.action_factors);  // "float": the action's in single precision
    solver["newton_rtol"] = n.rtol;
    solver["newton_atol"] = n.atol;
    solver["newton_max_iterations"] = n.max_iterations;
    solver["line_search"] = n.line_search;
    solver["tangent"] = n.tangent == TangentKind::consistent ? "consistent" : "initial";
  }
  nlohmann::ordered_json info = {{"particles", s.particles},
                                 {"fictitious", s.fictitious},
                                 {"bonds", s.bonds},
                                 {"cut_bonds", s.cut_bonds},
                                 {"unknowns", s.unknowns},
                                 {"tangent_nonzeros", s.nonzeros},
                                 {"threads", threads},
                                 {"malloc_huge_pages", malloc_huge_pages_state()},
                                 {"ranks", s.ranks},
                                 {"spacing", scene.discretization.spacing},
                                 {"horizon_factor", scene.discretization.horizon_factor},
                                 {"load_steps", scene.loading.steps},
                                 {"solver", solver},
                                 {"checks", checks}};
  // Under mpirun: how the rows were split (solver.belos.partition).
  if (s.ranks > 1 || s.part) {
    info["model"] = s.part ? "part" : "whole";  // every rank its part (docs/guide/distributed.md)
    info["partition"] = to_string(scene.solver.linear.belos.partition);
    info["bonds_held"] = s.bonds_partitioned ? "partitioned" : "whole";
    if (s.bonds_partitioned) info["largest_rank_bonds"] = s.largest_rank_bonds;
    if (s.part) info["largest_rank_particles"] = s.largest_rank_particles;
  }
  {
    const SurfaceCorrectionStats& c = s.correction_stats;
    nlohmann::ordered_json sc = {
        {"method", s.correction == SurfaceCorrectionMethod::moments ? "moments" : "none"}};
    if (s.correction == SurfaceCorrectionMethod::moments) {
      sc["corrected_families"] = c.corrected;
      sc["at_bound"] = c.clipped;
      sc["unmatched"] = c.unmatched;
      sc["min_influence"] = c.min_influence;
      sc["max_influence"] = c.max_influence;
      sc["seconds"] = c.seconds;
    }
    info["surface_correction"] = sc;
  }
  if (scene.contact.enabled) {
    const ContactOptions& c = scene.contact;
    nlohmann::ordered_json contact = {{"enforcement", to_string(c.enforcement)},
                                      {"normal", c.normal == NormalLaw::paper ? "paper" : "pair"},
                                      {"friction", c.friction},
                                      {"radius_factor", c.radius_factor},
                                      {"stiffness", c.stiffness}};
    if (c.enforcement == ContactEnforcement::exact) {
      contact["closure_tolerance"] = c.closure_tolerance;
      contact["closure_reference"] = to_string(c.closure_reference);
    }
    if (c.enforcement == ContactEnforcement::exact && c.friction > 0.0 && !c.velocity_sign)
      contact["stick"] = c.exact_stick ? "exact" : "penalty";
    info["contact"] = contact;
  }
  return info.dump();
}

/// The energy ledger up to the recorded state into `rec`'s counts.
void add_energy_counts(StepRecord& rec, const EnergyLedger& e) {
  // The energy ledger up to this state (docs/guide/results.md).
  rec.counts["energy_external_work"] = e.external_work;
  rec.counts["energy_strain"] = e.strain_energy;
  rec.counts["energy_contact_work"] = e.contact_work;
  rec.counts["energy_residual_work"] = e.residual_work;
  rec.counts["energy_released"] = e.released;
  rec.counts["energy_quadrature"] = e.quadrature;
  rec.counts["energy_worst_relative"] = e.worst_relative;
}

/// The bond failure's counts of step s (broken bonds, criterion peak, fragments) into `rec`.
void add_failure_counts(StepRecord& rec, const QuasiStaticProblem& problem, const BondFailure& failure,
                        const StepReport& s, Index fragment_contacts) {
  rec.counts["bonds_broken"] = s.bonds_broken;
  rec.counts["broken_bonds_total"] = failure.broken();
  rec.counts["resolves"] = s.resolves;
  rec.counts["break_cutbacks"] = s.break_cutbacks;
  // The intact pair closest to breaking at the step's final state (docs/guide/results.md).
  const BondFailure::Peak peak = failure.peak();
  rec.counts["criterion_peak"] = peak.ratio;
  rec.counts["fragments"] = problem.fragments();
  rec.counts["fragment_particles"] = problem.fragment_particles();
  if (problem.contact()) {
    rec.counts["fragment_contacts"] = fragment_contacts;
    rec.counts["fragment_reaction"] = problem.fragment_reaction();
  }
  if (peak.i >= 0) {
    rec.counts["criterion_peak_x"] = peak.at.x();
    rec.counts["criterion_peak_y"] = peak.at.y();
  }
}

/// The contact pairs' counts of step s (states, distances, multiplier updates) into `rec`.
void add_contact_counts(StepRecord& rec, const ContactSystem& contact, bool exact, const StepReport& s) {
  const ContactCounts& c = contact.counts();
  rec.counts["contact_candidates"] = c.candidates;
  rec.counts["contact_open"] = c.open;
  rec.counts["contact_stick"] = c.stick;
  rec.counts["contact_slip"] = c.slip;
  rec.counts["contact_min_distance"] = contact.min_distance();
  rec.counts["contact_max_closure"] = contact.max_closure();
  if (exact) rec.counts["multiplier_updates"] = s.multiplier_updates;
}

}  // namespace

std::string compliance_warning(const QuasiStaticProblem& problem, const StepReport& step) {
  const ContactSystem* contact = problem.contact();
  if (!contact) return {};
  const double closure = contact->max_closure(), radius = contact->law().radius;
  if (!(closure > 0.5 * radius)) return {};
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "step %d: the largest contact closure, %.3g dx, exceeds half the contact radius (%.3g dx): the "
                "answer leans on the penalty's compliance (contact.enforcement: exact removes it)",
                step.step, closure / problem.model().spacing, radius / problem.model().spacing);
  return buf;
}

StepRecorder::StepRecorder(const std::string& dir, const Scene& scene, const QuasiStaticProblem& problem,
                           const WholeView& view, const ModelSize& size, const std::string& linear,
                           int threads, int resume_after, bool writes)
    : m_scene(scene), m_problem(&problem), m_view(&view) {
  if (resume_after >= 0) {
    if (writes)
      m_writer = std::make_unique<ResultsWriter>(
          dir, scene.name, resume_after, view.particles(),
          run_info_json(scene, size, linear, threads, problem.state_checks()));
    return;
  }
  ParticleTable table = view.particle_table(scene);  // collective
  if (writes)
    m_writer =
        std::make_unique<ResultsWriter>(dir, scene.name, scene.text, std::move(table),
                                        run_info_json(scene, size, linear, threads, problem.state_checks()));
}

void StepRecorder::rebind(const QuasiStaticProblem& problem, const WholeView& view) {
  m_problem = &problem;
  m_view = &view;
  m_contact_seconds_before = 0.0;  // the new problem's timings start at zero
}

void StepRecorder::gather_contact_fields(const ContactSystem& contact) {
  contact.contact_force(m_contact_force);
  contact.particle_states(m_contact_state);
  // A part's own particles' values, the whole model's on rank 0 (the states exact in doubles).
  VectorXd mine = m_contact_force, whole;
  m_view->particle_values(mine, 2, m_contact_force);
  mine.resize(static_cast<Index>(m_contact_state.size()));
  for (std::size_t q = 0; q < m_contact_state.size(); ++q) mine[static_cast<Index>(q)] = m_contact_state[q];
  m_view->particle_values(mine, 1, whole);
  m_contact_state.assign(whole.data(), whole.data() + whole.size());
}

bool StepRecorder::due(int step) const {
  return step % m_scene.output.every == 0 || step == m_scene.loading.steps;
}

void StepRecorder::add_step_warnings(const StepReport& s) {
  if (std::string warning = compliance_warning(*m_problem, s); !warning.empty()) m_writer->add_warning(warning);
  if (m_problem->fragment_particles() > m_fragment_particles) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "step %d: %ld particles in %ld fragments have lost every bond to the prescribed displacements: "
                  "held where they were and taken out of the system (to the rest of the model they are fixed "
                  "obstacles)",
                  s.step, static_cast<long>(m_problem->fragment_particles()), static_cast<long>(m_problem->fragments()));
    std::fprintf(stderr, "WARNING: %s\n", buf);
    m_writer->add_warning(buf);
    m_fragment_particles = m_problem->fragment_particles();
  }
  if (!m_fragment_contact_warned && m_problem->fragment_particles() > 0 && m_fragment_contacts > 0) {
    char buf[320];
    std::snprintf(
        buf, sizeof buf,
        "step %d: %ld contact pairs press on held fragments, which act as fixed obstacles: their net "
        "reaction of %.3g N is not balanced by the model (counts fragment_contacts, fragment_reaction)",
        s.step, static_cast<long>(m_fragment_contacts), m_problem->fragment_reaction());
    std::fprintf(stderr, "WARNING: %s\n", buf);
    m_writer->add_warning(buf);
    m_fragment_contact_warned = true;
  }
}

void StepRecorder::record(const StepReport& s, const VectorXd& x) {
  double step_contact_seconds = 0.0;  // since the previous step (recorded or not)
  // Collective on the parts: every rank counts, rank 0 writes.
  if (m_problem->failure() && m_problem->contact()) m_fragment_contacts = m_problem->fragment_contacts();
  if (m_writer) {
    step_contact_seconds = m_problem->contact_seconds() - m_contact_seconds_before;
    m_contact_seconds_before = m_problem->contact_seconds();
    add_step_warnings(s);
  }
  if (!due(s.step)) return;
  gather_step_fields(x);
  if (!m_writer) return;
  write_record(s, step_contact_seconds);
}

void StepRecorder::gather_step_fields(const VectorXd& x) {
  // The fields and the reactions, the whole model's: collective on the parts, so every rank
  // computes them; rank 0 alone writes.
  m_problem->expand(x, m_u);
  m_view->particle_values(m_u, 2, m_u_whole);
  m_reactions.clear();
  for (std::size_t k = 0; k < m_scene.boundary.size(); ++k) m_reactions.push_back(m_problem->reaction(k));
  const ContactSystem* contact = m_problem->contact();
  if (contact) gather_contact_fields(*contact);  // the commit evaluated the pairs at this state
  if (m_problem->failure()) {                     // the committed state's
    const VectorXd mine = m_problem->damage();
    m_view->particle_values(mine, 1, m_damage);
    const std::vector<char>& held = m_problem->particles_held();
    VectorXd held_whole;
    m_view->particle_values(Eigen::Map<const Eigen::Matrix<char, Eigen::Dynamic, 1>>(
                                held.data(), static_cast<Eigen::Index>(held.size()))
                                .cast<double>(),
                            1, held_whole);
    m_held.assign(held_whole.begin(), held_whole.end());
  }
}

void StepRecorder::write_record(const StepReport& s, double step_contact_seconds) {
  const ContactSystem* contact = m_problem->contact();
  StepRecord rec;
  rec.index = s.step;
  rec.load_factor = s.load_factor;
  rec.newton_iterations = s.newton_iterations;
  rec.active_set_iterations = s.active_set_changes;
  rec.residual_norm = s.final_residual;
  rec.wall_seconds = s.wall_seconds;
  rec.displacement = &m_u_whole;
  rec.residual_history = s.residuals;
  rec.counts = {{"substeps", s.substeps},
                {"cutbacks", s.cutbacks},
                {"factorizations", s.factorizations},
                {"linear_iterations", s.linear_iterations},
                {"predictor_solves", s.predictor_solves}};
  // The force each boundary condition applies (docs/guide/results.md).
  for (std::size_t k = 0; k < m_reactions.size(); ++k) {
    const Vec2& f = m_reactions[k];
    rec.counts["reaction_" + std::to_string(k) + "_x"] = f.x();
    rec.counts["reaction_" + std::to_string(k) + "_y"] = f.y();
  }
  add_energy_counts(rec, m_problem->energy_ledger());
  if (const BondFailure* failure = m_problem->failure()) {
    rec.damage = &m_damage;
    rec.held = &m_held;
    add_failure_counts(rec, *m_problem, *failure, s, m_fragment_contacts);
  }
  if (m_scene.solver.type == SolverKind::adr) {
    rec.counts["adr_iterations"] = s.newton_iterations;
    rec.counts["unconverged_substeps"] = s.unconverged;
  }
  if (contact) {
    rec.contact_force = &m_contact_force;
    rec.contact_state = &m_contact_state;
    add_contact_counts(rec, *contact, m_scene.contact.enforcement == ContactEnforcement::exact, s);
  }
  rec.timings = {
      {"evaluate", s.seconds_evaluate}, {"factorize", s.seconds_factorize}, {"solve", s.seconds_solve}};
  if (m_problem->contact()) rec.timings["contact"] = step_contact_seconds;
  const WriteGuard guard;
  m_writer->write_step(rec);
}

}  // namespace peristat
