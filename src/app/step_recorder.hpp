// The results record of `peristat run` (docs/guide/results.md): the HDF5, XDMF and summary.json
// files through ResultsWriter, one converged step at a time, every `output.every` steps and
// the last.
#pragma once

#include <memory>
#include <string>

#include "app/model_size.hpp"
#include "app/whole_view.hpp"
#include "io/results.hpp"
#include "scene/scene.hpp"
#include "solvers/load_stepping.hpp"

namespace peristat {

/// The warning a converged step deserves, or "": the largest closure of a contact pair in
/// contact exceeds half the contact radius, so the answer leans on the penalty's compliance
/// (docs/theory/contact.md, section 9).
std::string compliance_warning(const QuasiStaticProblem& problem, const StepReport& step);

class StepRecorder {
 public:
  /// Creates the files in `dir` with the scene, the particles and the run information
  /// (model size, resolved options; `linear` is the linear solver's name, empty for ADR).
  /// With `resume_after` >= 0 the files of a stopped run in `dir` are continued after that
  /// step instead (ResultsWriter's resume constructor). Without `writes` (the ranks other
  /// than 0 of a distributed run) nothing is written; every call does nothing unless `view`
  /// gathers (a run on the parts), where every rank must make every call alike (collective).
  StepRecorder(const std::string& dir, const Scene& scene, const QuasiStaticProblem& problem,
               const WholeView& view, const ModelSize& size, const std::string& linear, int threads,
               int resume_after = -1, bool writes = true);

  /// Whether step k is written (every output.every-th and the last).
  bool due(int step) const;
  /// Writes the converged step s with state x when it is due, and its warning (every step).
  /// The contact counts and forces are those of the problem's last evaluation (the commit's, at x).
  void record(const StepReport& s, const VectorXd& x);
  /// The final status ("completed", "no_convergence", "interrupted") and message.
  void finish(const std::string& status, const std::string& message) {
    if (m_writer) m_writer->finish(status, message);
  }
  /// A warning of the run as a whole (summary.json `warnings`).
  void add_warning(const std::string& text) {
    if (m_writer) m_writer->add_warning(text);
  }
  std::string h5_path() const { return m_writer ? m_writer->h5_path() : std::string(); }
  /// Sets run.<key> in summary.json (ResultsWriter::set_run_value; rank 0 only).
  void set_run_value(const std::string& key, long long value) {
    if (m_writer) m_writer->set_run_value(key, value);
  }
  /// Records from `problem` and `view` from now on: the run re-cut its parts (PartsOutgrown)
  /// and rebuilt them; the whole model, and so the files, are the same.
  void rebind(const QuasiStaticProblem& problem, const WholeView& view);

 private:
  /// The warnings a converged step deserves (compliance, fragments), into the record (rank 0).
  void add_step_warnings(const StepReport& s);
  /// The contact force and state of each particle into m_contact_force and m_contact_state:
  /// the whole model's on rank 0 (collective on the parts).
  void gather_contact_fields(const ContactSystem& contact);
  /// The displacements, reactions, contact fields and damage of state x into the members:
  /// the whole model's on rank 0 (collective on the parts).
  void gather_step_fields(const VectorXd& x);
  /// Writes the due step s from the gathered fields (rank 0); `step_contact_seconds` is the
  /// contact evaluation time since the previous step.
  void write_record(const StepReport& s, double step_contact_seconds);

  const Scene& m_scene;
  const QuasiStaticProblem* m_problem;  ///< never null (rebind())
  const WholeView* m_view;
  std::unique_ptr<ResultsWriter> m_writer;
  double m_contact_seconds_before = 0.0;  ///< contact evaluation time up to the previous step
  Index m_fragment_particles = 0;         ///< fragment particles already warned about
  bool m_fragment_contact_warned = false;  ///< contact on held fragments already warned about
  VectorXd m_u, m_u_whole, m_contact_force, m_damage;
  std::vector<int> m_held;        ///< the whole model's held flags (with failure)
  Index m_fragment_contacts = 0;  ///< of the step being recorded (collective on the parts)
  std::vector<Vec2> m_reactions;  ///< of each boundary condition at the recorded step
  std::vector<int> m_contact_state;
};

}  // namespace peristat
