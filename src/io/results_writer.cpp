// ResultsWriter: DIR/<name>.h5, DIR/<name>.xdmf and DIR/summary.json (docs/guide/results.md).
#include <cmath>
#include <filesystem>
#include <memory>
#include <numeric>
#include <set>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "io/h5.hpp"
#include "io/layout.hpp"
#include "io/results.hpp"
#include "io/safe_write.hpp"
#include "io/xdmf.hpp"

namespace peristat {
namespace {

namespace fs = std::filesystem;

/// Attribute names every step group carries; counts and timings may not reuse them.
const std::set<std::string>& fixed_step_attributes() {
  static const std::set<std::string> names = {"load_factor", "newton_iterations", "active_set_iterations",
                                              "residual_norm", "wall_seconds"};
  return names;
}

/// What summary.json and the XDMF need from a written step.
struct StepSummary : StepFigures {
  bool has_damage = false;
  bool has_contact_force = false;
};

StepSummary summarise(const StepRecord& step) {
  StepSummary s;
  static_cast<StepFigures&>(s) = step;
  s.has_damage = step.damage != nullptr;
  s.has_contact_force = step.contact_force != nullptr;
  return s;
}

void check_particles(const ParticleTable& p) {
  const std::size_t n = p.size();
  if (p.volume.size() != n || p.body.size() != n || p.fictitious.size() != n) {
    throw std::invalid_argument("ResultsWriter: particle table columns differ in length (position " +
                                std::to_string(n) + ", volume " + std::to_string(p.volume.size()) +
                                ", body " + std::to_string(p.body.size()) + ", fictitious " +
                                std::to_string(p.fictitious.size()) + ")");
  }
}

void check_field(const VectorXd* field, std::size_t expected, const char* name, int index) {
  if (field != nullptr && static_cast<std::size_t>(field->size()) != expected) {
    throw std::invalid_argument("ResultsWriter: step " + std::to_string(index) + ": " + name + " has " +
                                std::to_string(field->size()) + " entries, expected " +
                                std::to_string(expected));
  }
}

/// Names of the per-entry attributes (counts as is, timings prefixed "time_"), checked
/// for clashes before anything is written.
void check_attribute_names(const StepRecord& step) {
  std::set<std::string> used = fixed_step_attributes();
  auto claim = [&](const std::string& name) {
    if (name.empty() || !used.insert(name).second) {
      throw std::invalid_argument("ResultsWriter: step " + std::to_string(step.index) +
                                  ": counts/timings entry '" + name +
                                  "' is empty or clashes with another step attribute");
    }
  };
  for (const auto& entry : step.counts) claim(entry.first);
  for (const auto& entry : step.timings) claim("time_" + entry.first);
}

void check_step(const StepRecord& step, std::size_t n, const std::vector<StepSummary>& written) {
  if (step.index < 1) {
    throw std::invalid_argument("ResultsWriter: step index must be >= 1, got " + std::to_string(step.index));
  }
  for (const StepSummary& s : written) {
    if (s.index == step.index) {
      throw std::invalid_argument("ResultsWriter: step " + std::to_string(step.index) +
                                  " was already written");
    }
  }
  if (step.displacement == nullptr) {
    throw std::invalid_argument("ResultsWriter: step " + std::to_string(step.index) + " has no displacement");
  }
  check_field(step.displacement, 2 * n, "displacement", step.index);
  check_field(step.damage, n, "damage", step.index);
  check_field(step.contact_force, 2 * n, "contact_force", step.index);
  check_attribute_names(step);
}

std::vector<double> flatten(const std::vector<Vec2>& points) {
  std::vector<double> xy;
  xy.reserve(2 * points.size());
  for (const Vec2& p : points) {
    xy.push_back(p.x());
    xy.push_back(p.y());
  }
  return xy;
}

void write_particles(const h5::File& file, const ParticleTable& p) {
  const auto n = static_cast<hsize_t>(p.size());
  h5::Handle group = file.create_group(file.id(), "particles");
  const std::vector<double> xy = flatten(p.position);
  file.write_doubles(group, "position", xy.data(), {n, 2});
  file.write_doubles(group, "volume", p.volume.data(), {n});
  file.write_ints(group, "body", p.body.data(), {n});
  file.write_ints(group, "fictitious", p.fictitious.data(), {n});
  // The XDMF's Polyvertex connectivity: one vertex cell per particle, 0 .. N-1 (without it
  // ParaView shows the points but no cell, and the default Surface view is empty).
  std::vector<int> vertex(p.size());
  std::iota(vertex.begin(), vertex.end(), 0);
  file.write_ints(group, "vertex", vertex.data(), {n});
  file.write_attribute(group, "spacing", p.spacing);
  file.write_attribute(group, "body_names", p.body_names);
}

void write_step_contents(const h5::File& file, hid_t group, const StepRecord& step) {
  const auto n = static_cast<hsize_t>(step.displacement->size() / 2);
  file.write_doubles(group, "displacement", step.displacement->data(), {n, 2});
  if (step.damage != nullptr) file.write_doubles(group, "damage", step.damage->data(), {n});
  if (step.contact_force != nullptr) {
    file.write_doubles(group, "contact_force", step.contact_force->data(), {n, 2});
  }
  file.write_doubles(group, "residual_history", step.residual_history.data(),
                     {static_cast<hsize_t>(step.residual_history.size())});
  file.write_attribute(group, "load_factor", step.load_factor);
  file.write_attribute(group, "newton_iterations", step.newton_iterations);
  file.write_attribute(group, "active_set_iterations", step.active_set_iterations);
  file.write_attribute(group, "residual_norm", step.residual_norm);
  file.write_attribute(group, "wall_seconds", step.wall_seconds);
  for (const auto& [key, value] : step.counts) file.write_attribute(group, key, value);
  for (const auto& [key, value] : step.timings) file.write_attribute(group, "time_" + key, value);
}

/// One entry of "steps" in summary.json (keys in this order; NaN and infinities become null).
nlohmann::ordered_json step_json(const StepSummary& s) {
  return {{"step", s.index},
          {"load_factor", s.load_factor},
          {"newton_iterations", s.newton_iterations},
          {"active_set_iterations", s.active_set_iterations},
          {"residual_norm", s.residual_norm},
          {"wall_seconds", s.wall_seconds},
          {"residual_history", s.residual_history},
          {"counts", s.counts},
          {"timings", s.timings}};
}

/// Writes integral floating-point values (counts, load factor 1) as JSON integers, "30" and
/// not "30.0", as summary.json has always had them; every other number keeps its shortest
/// round-trip form.
void integral_floats_as_integers(nlohmann::ordered_json& j) {
  constexpr double kExactIntegers = 9007199254740992.0;  // 2^53: larger doubles may not be integers exactly
  if (j.is_structured()) {
    for (auto& item : j) integral_floats_as_integers(item);
  } else if (j.is_number_float()) {
    const double v = j.get<double>();
    if (std::isfinite(v) && v == std::trunc(v) && std::abs(v) < kExactIntegers &&
        !(v == 0.0 && std::signbit(v)))
      j = static_cast<long long>(v);
  }
}

/// The run info text as a JSON value: null when blank, else it must be a JSON object.
nlohmann::ordered_json parse_run_info(const std::string& text) {
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) return nullptr;
  nlohmann::ordered_json info = nlohmann::ordered_json::parse(text, nullptr, false);
  if (!info.is_object()) {
    throw std::invalid_argument("ResultsWriter: the run info is not a JSON object: " + text);
  }
  return info;
}

}  // namespace

struct ResultsWriter::Impl {
  std::string name;
  fs::path dir;
  nlohmann::ordered_json run_info;
  std::size_t n_particles = 0;
  std::vector<StepSummary> steps;
  std::string status = "running";
  std::string message;
  std::vector<std::string> warnings;

  fs::path h5() const { return dir / (name + ".h5"); }
  fs::path xdmf() const { return dir / (name + ".xdmf"); }
  fs::path summary() const { return dir / "summary.json"; }

  void create_h5(const std::string& scene_text, const ParticleTable& particles) const {
    const std::string temporary = h5().string() + ".tmp";
    h5::File file = h5::File::create(temporary);
    file.write_attribute(file.id(), "scene", scene_text);
    write_particles(file, particles);
    file.create_group(file.id(), "steps");
    file.close();
    std::error_code error;
    fs::rename(temporary, h5(), error);
    if (error) {
      throw std::runtime_error("cannot rename '" + temporary + "' to '" + h5().string() +
                               "': " + error.message());
    }
  }

  /// Appends /steps/<index>; a group left half-written by a failure is removed again.
  void append_h5(const StepRecord& step) const {
    h5::File file = h5::File::open(h5().string(), true);
    const std::string group_name = io::step_group_name(step.index);
    {
      h5::Handle steps_group = file.open_group(file.id(), "steps");
      try {
        h5::Handle group = file.create_group(steps_group, group_name);
        write_step_contents(file, group, step);
      } catch (...) {
        try {
          if (file.link_exists(steps_group, group_name)) file.delete_link(steps_group, group_name);
        } catch (...) {  // NOLINT(bugprone-empty-catch): the first error is the one to report
        }
        throw;
      }
    }
    file.close();
  }

  void write_xdmf() const {
    std::vector<io::XdmfStep> xs;
    xs.reserve(steps.size());
    for (const StepSummary& s : steps) {
      xs.push_back({s.index, s.load_factor, s.has_damage, s.has_contact_force});
    }
    io::write_file_atomically(xdmf().string(), io::xdmf_document(name + ".h5", n_particles, xs));
  }

  /// Pretty-printed; bytes that are not UTF-8 (a message quoting a file name, say) are
  /// written as U+FFFD rather than failing the write.
  void write_summary() const {
    nlohmann::ordered_json doc = {
        {"scene", name}, {"status", status}, {"message", message}, {"warnings", warnings}, {"run", run_info}};
    nlohmann::ordered_json& list = doc["steps"] = nlohmann::ordered_json::array();
    for (const StepSummary& s : steps) list.push_back(step_json(s));
    integral_floats_as_integers(doc);
    const std::string text = doc.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
    io::write_file_atomically(summary().string(), text + "\n");
  }
};

ResultsWriter::ResultsWriter(const std::string& dir, const std::string& name, const std::string& scene_text,
                             const ParticleTable& particles, const std::string& run_info_json)
    : m_impl(nullptr) {
  if (name.empty()) throw std::invalid_argument("ResultsWriter: empty scene name");
  check_particles(particles);
  auto impl = std::make_unique<Impl>();
  impl->name = name;
  impl->dir = fs::path(dir);
  impl->run_info = parse_run_info(run_info_json);
  impl->n_particles = particles.size();

  std::error_code error;
  fs::create_directories(impl->dir, error);
  if (error) {
    throw std::runtime_error("cannot create results directory '" + dir + "': " + error.message());
  }
  const io::SignalBlocker hold_signals;
  impl->create_h5(scene_text, particles);
  impl->write_xdmf();
  impl->write_summary();
  m_impl = impl.release();
}

ResultsWriter::~ResultsWriter() {
  delete m_impl;
}

void ResultsWriter::write_step(const StepRecord& step) {
  check_step(step, m_impl->n_particles, m_impl->steps);
  const io::SignalBlocker hold_signals;
  m_impl->append_h5(step);
  m_impl->steps.push_back(summarise(step));
  m_impl->write_xdmf();
  m_impl->write_summary();
}

void ResultsWriter::finish(const std::string& status, const std::string& message) {
  static const std::set<std::string> allowed = {"running", "completed", "no_convergence", "interrupted",
                                                "error"};
  if (allowed.count(status) == 0) {
    throw std::invalid_argument("ResultsWriter::finish: unknown status '" + status + "'");
  }
  const io::SignalBlocker hold_signals;
  m_impl->status = status;
  m_impl->message = message;
  m_impl->write_summary();
}

void ResultsWriter::add_warning(const std::string& text) {
  m_impl->warnings.push_back(text);
}

std::string ResultsWriter::h5_path() const {
  return m_impl->h5().string();
}

}  // namespace peristat
