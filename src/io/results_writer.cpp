// ResultsWriter: DIR/<name>.h5, DIR/<name>.xdmf and DIR/summary.json (docs/guide/results.md).
#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <stdexcept>
#include <utility>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "core/version.hpp"
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
  bool has_contact_state = false;
  bool has_held = false;
};

StepSummary summarise(const StepRecord& step) {
  StepSummary s;
  static_cast<StepFigures&>(s) = step;
  s.has_damage = step.damage != nullptr;
  s.has_contact_force = step.contact_force != nullptr;
  s.has_contact_state = step.contact_state != nullptr;
  s.has_held = step.held != nullptr;
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
  for (const auto& [field, name] :
       {std::pair{step.contact_state, "contact_state"}, std::pair{step.held, "held"}}) {
    if (field != nullptr && field->size() != n) {
      throw std::invalid_argument("ResultsWriter: step " + std::to_string(step.index) + ": " + name +
                                  " has " + std::to_string(field->size()) + " entries, expected " +
                                  std::to_string(n));
    }
  }
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
  if (step.contact_state != nullptr) file.write_ints(group, "contact_state", step.contact_state->data(), {n});
  if (step.held != nullptr) file.write_ints(group, "held", step.held->data(), {n});
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

/// The inverse of step_json (figures only), for a resumed run's earlier steps.
/// Which fields a kept step group of a resumed run holds.
struct StepFields {
  bool damage = false, contact_force = false, contact_state = false, held = false;
};

StepSummary step_from_json(const nlohmann::ordered_json& j, const StepFields& fields) {
  StepSummary s;
  const auto number = [](const nlohmann::ordered_json& v) {
    return v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
  };
  s.index = j.value("step", 0);
  s.load_factor = number(j.value("load_factor", nlohmann::ordered_json()));
  s.newton_iterations = j.value("newton_iterations", 0);
  s.active_set_iterations = j.value("active_set_iterations", 0);
  s.residual_norm = number(j.value("residual_norm", nlohmann::ordered_json()));
  s.wall_seconds = number(j.value("wall_seconds", nlohmann::ordered_json()));
  if (j.contains("residual_history"))
    for (const auto& v : j["residual_history"]) s.residual_history.push_back(number(v));
  for (const char* map : {"counts", "timings"})
    if (j.contains(map) && j[map].is_object())
      for (const auto& [key, v] : j[map].items()) (map[0] == 'c' ? s.counts : s.timings)[key] = number(v);
  s.has_damage = fields.damage;
  s.has_contact_force = fields.contact_force;
  s.has_contact_state = fields.contact_state;
  s.has_held = fields.held;
  return s;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
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
    file.write_attribute(file.id(), "peristat_version", std::string(program_version()));
    file.write_attribute(file.id(), "peristat_commit", std::string(program_commit()));
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

  /// Appends /steps/<index> to a copy of the file and renames the copy over it (the file is
  /// whole at every instant); a copy left half-written by a failure is removed.
  void append_h5(const StepRecord& step) const {
    const std::string temporary = h5().string() + ".tmp";
    edit_copy(temporary, [&](h5::File& file) {
      h5::Handle steps_group = file.open_group(file.id(), "steps");
      h5::Handle group = file.create_group(steps_group, io::step_group_name(step.index));
      write_step_contents(file, group, step);
      if (const char* at = std::getenv("PERISTAT_FAULT_KILL_IN_WRITE"); at && std::atoi(at) == step.index) {
        group = h5::Handle();
        steps_group = h5::Handle();
        std::raise(SIGKILL);  // fault injection for tests: a stop inside the step write
      }
    });
  }

  /// Copies the HDF5 file to `temporary`, lets `edit` change the copy, renames it over the file.
  template <class Edit>
  void edit_copy(const std::string& temporary, Edit&& edit) const {
    std::error_code error;
    fs::copy_file(h5(), temporary, fs::copy_options::overwrite_existing, error);
    if (error) throw std::runtime_error("cannot copy '" + h5().string() + "' to '" + temporary + "': " + error.message());
    try {
      h5::File file = h5::File::open(temporary, true);
      edit(file);
      file.close();
    } catch (...) {
      fs::remove(temporary, error);
      throw;
    }
    fs::rename(temporary, h5(), error);
    if (error) throw std::runtime_error("cannot rename '" + temporary + "' to '" + h5().string() + "': " + error.message());
  }

  /// Resume: removes the step groups after `last_step`; returns which of the others hold
  /// damage, contact fields and held flags (by step index).
  std::map<int, StepFields> keep_steps_up_to(int last_step) const {
    std::map<int, StepFields> kept;
    edit_copy(h5().string() + ".tmp", [&](h5::File& file) {
      h5::Handle steps_group = file.open_group(file.id(), "steps");
      for (const std::string& group_name : file.link_names(steps_group)) {
        const int index = std::atoi(group_name.c_str());
        if (index > last_step || index < 1) {
          file.delete_link(steps_group, group_name);
          continue;
        }
        h5::Handle group = file.open_group(steps_group, group_name);
        kept[index] = {file.link_exists(group, "damage"), file.link_exists(group, "contact_force"),
                       file.link_exists(group, "contact_state"), file.link_exists(group, "held")};
      }
    });
    return kept;
  }

  void write_xdmf() const {
    std::vector<io::XdmfStep> xs;
    xs.reserve(steps.size());
    for (const StepSummary& s : steps) {
      xs.push_back(
          {s.index, s.load_factor, s.has_damage, s.has_contact_force, s.has_contact_state, s.has_held});
    }
    io::write_file_atomically(xdmf().string(), io::xdmf_document(name + ".h5", n_particles, xs));
  }

  /// Pretty-printed; bytes that are not UTF-8 (a message quoting a file name, say) are
  /// written as U+FFFD rather than failing the write.
  void write_summary() const {
    nlohmann::ordered_json doc = {
        {"scene", name},
        {"status", status},
        {"message", message},
        {"warnings", warnings},
        {"program", {{"name", "peristat"}, {"version", program_version()}, {"commit", program_commit()}}},
        {"run", run_info}};
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

ResultsWriter::ResultsWriter(const std::string& dir, const std::string& name, int last_step, std::size_t n_particles,
                             const std::string& run_info_json)
    : m_impl(nullptr) {
  auto impl = std::make_unique<Impl>();
  impl->name = name;
  impl->dir = fs::path(dir);
  impl->run_info = parse_run_info(run_info_json);
  impl->n_particles = n_particles;
  if (!fs::exists(impl->h5())) throw InputError(impl->h5().string() + ": no results to resume");
  const io::SignalBlocker hold_signals;
  std::map<int, StepFields> kept;
  try {
    const h5::File file = h5::File::open(impl->h5().string(), false);
    const std::vector<hsize_t> shape = file.shape(file.id(), "particles/volume");
    if (shape.size() != 1 || shape[0] != n_particles)
      throw InputError(impl->h5().string() + ": holds another model (" + std::to_string(shape.empty() ? 0 : shape[0]) +
                       " particles, the scene has " + std::to_string(n_particles) + ")");
  } catch (const std::runtime_error& e) {
    if (dynamic_cast<const InputError*>(&e)) throw;
    throw InputError(std::string("cannot resume: ") + e.what());
  }
  kept = impl->keep_steps_up_to(last_step);
  // summary.json: the steps up to last_step that the HDF5 file holds, and the warnings.
  nlohmann::ordered_json summary =
      nlohmann::ordered_json::parse(read_text(impl->summary()), nullptr, false);
  if (summary.is_object()) {
    if (summary.contains("warnings") && summary["warnings"].is_array())
      for (const auto& w : summary["warnings"])
        if (w.is_string()) impl->warnings.push_back(w.get<std::string>());
    if (summary.contains("steps") && summary["steps"].is_array())
      for (const auto& j : summary["steps"]) {
        const int index = j.value("step", 0);
        const auto it = kept.find(index);
        if (it == kept.end()) continue;
        impl->steps.push_back(step_from_json(j, it->second));
      }
  }
  for (const auto& [index, fields] : kept) {
    const bool listed = std::any_of(impl->steps.begin(), impl->steps.end(), [&](const StepSummary& x) { return x.index == index; });
    if (!listed) throw InputError(impl->summary().string() + ": does not list step " + std::to_string(index) +
                                  " of " + impl->h5().string() + "; cannot resume");
  }
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

void ResultsWriter::set_run_value(const std::string& key, long long value) {
  if (!m_impl->run_info.is_object()) m_impl->run_info = nlohmann::ordered_json::object();
  m_impl->run_info[key] = value;
}

std::string ResultsWriter::h5_path() const {
  return m_impl->h5().string();
}

}  // namespace peristat
