#include "app/step_recorder.hpp"

#include "app/interrupt.hpp"
#include "io/json.hpp"

namespace peristat {

namespace {

/// The resolved options and model size, stored under "run" in summary.json.
std::string run_info_json(const Scene& scene, const ModelSize& s, const std::string& linear, int threads) {
  const NewtonOptions& n = scene.solver.newton;
  json::Writer w;
  w.begin_object();
  w.field("particles", s.particles);
  w.field("fictitious", s.fictitious);
  w.field("bonds", s.bonds);
  w.field("cut_bonds", s.cut_bonds);
  w.field("unknowns", s.unknowns);
  w.field("tangent_nonzeros", s.nonzeros);
  w.field("threads", threads);
  w.field("spacing", scene.discretization.spacing);
  w.field("horizon_factor", scene.discretization.horizon_factor);
  w.field("load_steps", scene.loading.steps);
  w.key("solver");
  w.begin_object();
  w.field("type", to_string(scene.solver.type));
  if (scene.solver.type == SolverKind::adr) {
    const AdrOptions& a = scene.solver.adr;
    w.field("adr_rtol", a.rtol);
    w.field("adr_max_iterations", static_cast<double>(a.max_iterations));
    w.field("adr_on_budget", a.accept_on_budget ? "accept" : "fail");
    w.field("adr_density_factor", a.density_factor);
  } else {
    w.field("linear", std::string_view(linear));
    w.field("newton_rtol", n.rtol);
    w.field("newton_atol", n.atol);
    w.field("newton_max_iterations", n.max_iterations);
    w.field("line_search", n.line_search);
    w.field("tangent", n.tangent == TangentKind::consistent ? "consistent" : "initial");
  }
  w.end_object();
  w.end_object();
  return w.str();
}

ParticleTable particle_table(const Scene& scene, const Model& model) {
  ParticleTable t;
  const Particles& p = model.particles;
  t.position = p.position;
  t.volume = p.volume;
  t.body = p.body;
  t.fictitious.assign(p.fictitious.begin(), p.fictitious.end());
  for (const Body& b : scene.bodies) t.body_names.push_back(b.name);
  t.spacing = model.spacing;
  return t;
}

}  // namespace

StepRecorder::StepRecorder(const std::string& dir, const Scene& scene, const QuasiStaticProblem& problem,
                           const ModelSize& size, const std::string& linear, int threads)
    : m_scene(scene),
      m_problem(problem),
      m_writer(dir, scene.name, scene.text, particle_table(scene, problem.model()),
               run_info_json(scene, size, linear, threads)) {}

bool StepRecorder::due(int step) const {
  return step % m_scene.output.every == 0 || step == m_scene.loading.steps;
}

void StepRecorder::record(const StepReport& s, const VectorXd& x) {
  const double step_contact_seconds = m_problem.contact_seconds() - m_contact_seconds_before;
  m_contact_seconds_before = m_problem.contact_seconds();
  if (!due(s.step)) return;
  m_problem.expand(x, m_u);
  StepRecord rec;
  rec.index = s.step;
  rec.load_factor = s.load_factor;
  rec.newton_iterations = s.newton_iterations;
  rec.active_set_iterations = s.active_set_changes;
  rec.residual_norm = s.final_residual;
  rec.wall_seconds = s.wall_seconds;
  rec.displacement = &m_u;
  rec.residual_history = s.residuals;
  rec.counts = {{"substeps", s.substeps},
                {"cutbacks", s.cutbacks},
                {"factorizations", s.factorizations},
                {"linear_iterations", s.linear_iterations}};
  if (const BondFailure* failure = m_problem.failure()) {
    failure->damage(m_damage);
    rec.damage = &m_damage;
    rec.counts["bonds_broken"] = s.bonds_broken;
    rec.counts["broken_bonds_total"] = failure->broken();
    rec.counts["resolves"] = s.resolves;
    rec.counts["break_cutbacks"] = s.break_cutbacks;
  }
  if (m_scene.solver.type == SolverKind::adr) {
    rec.counts["adr_iterations"] = s.newton_iterations;
    rec.counts["unconverged_substeps"] = s.unconverged;
  }
  if (const ContactSystem* contact = m_problem.contact()) {
    // The commit evaluated the pairs at this state (before updating the slip history).
    contact->contact_force(m_contact_force);
    rec.contact_force = &m_contact_force;
    const ContactCounts& c = contact->counts();
    rec.counts["contact_candidates"] = c.candidates;
    rec.counts["contact_open"] = c.open;
    rec.counts["contact_stick"] = c.stick;
    rec.counts["contact_slip"] = c.slip;
    rec.counts["contact_min_distance"] = contact->min_distance();
  }
  rec.timings = {{"evaluate", s.seconds_evaluate}, {"factorize", s.seconds_factorize}, {"solve", s.seconds_solve}};
  if (m_problem.contact()) rec.timings["contact"] = step_contact_seconds;
  const WriteGuard guard;
  m_writer.write_step(rec);
}

}  // namespace peristat
