// Results files (docs/guide/results.md): DIR/<name>.h5, DIR/<name>.xdmf, DIR/summary.json.
// The writer keeps every file valid between steps: the HDF5 file is created under a
// temporary name and renamed, then reopened, appended and closed once per converged step
// (SIGINT/SIGTERM are held back while a step is written), and the XDMF and JSON files are
// rewritten through a temporary file and a rename. A killed run leaves files holding every
// step completed before the kill.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace peristat {

/// Reference configuration, written once under /particles.
struct ParticleTable {
  std::vector<Vec2> position;           ///< N reference positions
  std::vector<double> volume;           ///< N volumes [m^3]
  std::vector<int> body;                ///< N body indices (Scene::bodies order)
  std::vector<int> fictitious;          ///< N flags, 1 for fictitious-layer particles
  std::vector<std::string> body_names;  ///< written as attribute /particles/body_names
  double spacing = 0.0;                 ///< dx, attribute of /particles
  std::size_t size() const { return position.size(); }
};

/// One converged load step.
/// The numbers of one converged load step (HDF5 attributes and summary.json).
struct StepFigures {
  int index = 0;  ///< 1-based step number -> group /steps/%06d
  double load_factor = 0.0;
  int newton_iterations = 0;
  int active_set_iterations = 0;
  double residual_norm = 0.0;             ///< final relative residual
  double wall_seconds = 0.0;              ///< wall time of this step
  std::vector<double> residual_history;   ///< relative residual per Newton iteration
  std::map<std::string, double> counts;   ///< e.g. "cutbacks", "open", "stick", "broken_bonds"
  std::map<std::string, double> timings;  ///< seconds, e.g. "assembly", "factorize", "solve"
};

/// One converged load step: its figures and its fields.
struct StepRecord : StepFigures {
  const VectorXd* displacement = nullptr;   ///< 2N, interleaved (ux0, uy0, ux1, ...)
  const VectorXd* damage = nullptr;         ///< N, only where failure is modelled
  const VectorXd* contact_force = nullptr;  ///< 2N, only where contact is modelled
  const std::vector<int>* contact_state = nullptr;  ///< N (0 no closed pair, 1 stick, 2 slip), with contact
  /// N (1: held as a fragment, docs/theory/failure.md "Fragments"), only where failure is modelled
  const std::vector<int>* held = nullptr;
};

/// Writes the three result files of a run.
class ResultsWriter {
 public:
  /// Creates DIR (and parents) if needed, writes /scene and /particles to
  /// DIR/<name>.h5 (via DIR/<name>.h5.tmp and a rename) and an initial summary.json.
  /// `run_info_json` is a JSON object text (model size, resolved options, ...) stored
  /// under "run" in summary.json (null if blank). Throws std::invalid_argument if it is not
  /// a JSON object, std::runtime_error on I/O failure.
  ResultsWriter(const std::string& dir, const std::string& name, const std::string& scene_text,
                const ParticleTable& particles, const std::string& run_info_json);
  /// Continues the files of a stopped run in DIR (peristat run --resume) after its step
  /// `last_step` (0: none): later step groups (written before the stop but after the
  /// checkpoint) are removed, summary.json's steps and warnings up to it are kept. Throws
  /// InputError naming the file when DIR holds no such results or they hold another model.
  ResultsWriter(const std::string& dir, const std::string& name, int last_step, std::size_t n_particles,
                const std::string& run_info_json);
  ~ResultsWriter();
  ResultsWriter(const ResultsWriter&) = delete;
  ResultsWriter& operator=(const ResultsWriter&) = delete;

  /// Appends /steps/<index> with its datasets and attributes, rewrites the XDMF and
  /// summary.json. Signals SIGINT/SIGTERM/SIGHUP are blocked while this runs. The HDF5 file
  /// is copied, the step appended to the copy and the copy renamed over the file, so that a
  /// stop at any instant (SIGKILL included) leaves the file as it was before or after.
  void write_step(const StepRecord& step);

  /// Records the final status ("completed", "no_convergence", "interrupted", "error") and a message in
  /// summary.json.
  void finish(const std::string& status, const std::string& message);

  /// Adds a warning to the "warnings" list of summary.json (written with the next step or
  /// finish()): a result the run accepted but the user should question.
  void add_warning(const std::string& text);
  /// Sets run.<key> in summary.json (written with the next step or finish()): a figure of the
  /// run known only as it goes (e.g. run.part_regrowths).
  void set_run_value(const std::string& key, long long value);

  std::string h5_path() const;

 private:
  struct Impl;
  Impl* m_impl;
};

/// Read access to a results file, for probe and compare. Every failure to read the file
/// (missing, not HDF5, not a peristat file, damaged: HDF5's own errors included) throws
/// InputError naming the file, from the constructor and from each accessor.
class ResultsReader {
 public:
  explicit ResultsReader(const std::string& h5_path);

  const ParticleTable& particles() const { return m_particles; }
  const std::string& scene_text() const { return m_scene_text; }
  /// Step numbers present, ascending (the K of /steps/K).
  const std::vector<int>& steps() const { return m_steps; }
  /// Displacement of step K (2N interleaved); throws if the step is absent.
  VectorXd displacement(int step) const;
  /// Damage of step K (N); throws if the step is absent or the run modelled no failure.
  VectorXd damage(int step) const;
  /// Contact state of step K (N: 0 no closed pair, 1 stick, 2 slip); throws if the step is
  /// absent or the run modelled no contact.
  VectorXd contact_state(int step) const;
  /// Which particles step K holds as fragments (N: 1 held, 0 not): their positions are not
  /// determined by the equations. All 0 for a step without the dataset (no failure modelled,
  /// or a file written before it existed); throws if the step is absent.
  VectorXd held(int step) const;
  double load_factor(int step) const;

 private:
  /// One value per particle of step K's dataset `name`; `absent` says why it may be missing.
  VectorXd per_particle(int step, const std::string& name, const std::string& absent) const;
  std::string m_path;
  ParticleTable m_particles;
  std::string m_scene_text;
  std::vector<int> m_steps;
};

/// One sampled point of a line profile.
struct ProbeSample {
  double s, x, y, ux, uy;
};

/// Samples the displacement of `step` at `n_points` equally spaced points from (x0,y0) to
/// (x1,y1) (reference coordinates). Interpolation: bilinear over the lattice cell of the
/// point, using the non-fictitious particles of the body of the nearest particle; where
/// corners are missing, inverse-distance weights of those present; NaN where no particle
/// of any body lies within one spacing.
std::vector<ProbeSample> probe_line(const ResultsReader& results, int step, Vec2 a, Vec2 b, int n_points);

}  // namespace peristat
