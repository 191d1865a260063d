// ResultsReader: read access to DIR/<name>.h5 for probe and compare.
#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "core/error.hpp"
#include "io/h5.hpp"
#include "io/layout.hpp"
#include "io/results.hpp"

namespace peristat {
namespace {

bool is_step_name(const std::string& name) {
  return !name.empty() && name.size() <= 9 &&
         std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::string describe_steps(const std::vector<int>& steps) {
  if (steps.empty()) return "the file holds no steps";
  std::string text = "steps present: ";
  if (steps.size() <= 10) {
    for (std::size_t i = 0; i < steps.size(); ++i) {
      text += (i > 0 ? ", " : "") + std::to_string(steps[i]);
    }
    return text;
  }
  return text + std::to_string(steps.front()) + " ... " + std::to_string(steps.back()) + " (" +
         std::to_string(steps.size()) + " steps)";
}

/// Opens the file read-only after checking that it exists and is HDF5 at all.
h5::File open_results(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    throw InputError("results file '" + path + "' does not exist or is not a regular file");
  }
  h5::silence_errors();
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    throw InputError("'" + path + "' is not an HDF5 file, so not a peristat results file");
  }
  return h5::File::open(path, false);
}

void require_layout(const h5::File& file) {
  const hid_t root = file.id();
  const bool ok = file.attribute_exists(root, "scene") && file.link_exists(root, "particles") &&
                  file.link_exists(root, "particles/position") &&
                  file.link_exists(root, "particles/volume") && file.link_exists(root, "particles/body") &&
                  file.link_exists(root, "particles/fictitious") && file.link_exists(root, "steps");
  if (!ok) {
    throw InputError("'" + file.path() +
                     "' is not a peristat results file (it lacks the /scene attribute, "
                     "/particles/{position,volume,body,fictitious} or /steps)");
  }
}

std::string shape_text(const std::vector<hsize_t>& dims) {
  std::string text;
  for (std::size_t i = 0; i < dims.size(); ++i) {
    text += (i > 0 ? " x " : "") + std::to_string(dims[i]);
  }
  return text;
}

void require_shape(const h5::File& file, const std::string& dataset, const std::vector<hsize_t>& want) {
  const std::vector<hsize_t> got = file.shape(file.id(), dataset);
  if (got != want) {
    throw InputError("'" + file.path() + "': dataset /" + dataset + " has shape [" + shape_text(got) +
                     "], expected [" + shape_text(want) + "] (is this a peristat results file?)");
  }
}

ParticleTable read_particles(const h5::File& file) {
  ParticleTable table;
  const std::vector<hsize_t> position_shape = file.shape(file.id(), "particles/position");
  if (position_shape.size() != 2 || position_shape[1] != 2) {
    throw InputError("'" + file.path() + "': /particles/position is not an N x 2 array");
  }
  const hsize_t n = position_shape[0];
  require_shape(file, "particles/volume", {n});
  require_shape(file, "particles/body", {n});
  require_shape(file, "particles/fictitious", {n});

  const std::vector<double> xy = file.read_doubles(file.id(), "particles/position");
  table.position.reserve(n);
  for (hsize_t i = 0; i < n; ++i) table.position.emplace_back(xy[2 * i], xy[2 * i + 1]);
  table.volume = file.read_doubles(file.id(), "particles/volume");
  table.body = file.read_ints(file.id(), "particles/body");
  table.fictitious = file.read_ints(file.id(), "particles/fictitious");

  h5::Handle group = file.open_group(file.id(), "particles");
  if (file.attribute_exists(group, "spacing")) {
    table.spacing = file.read_double_attribute(group, "spacing");
  }
  if (file.attribute_exists(group, "body_names")) {
    table.body_names = file.read_string_array_attribute(group, "body_names");
  }
  return table;
}

std::vector<int> read_step_numbers(const h5::File& file) {
  h5::Handle group = file.open_group(file.id(), "steps");
  std::vector<int> steps;
  for (const std::string& name : file.link_names(group)) {
    if (is_step_name(name)) steps.push_back(std::stoi(name));
  }
  std::sort(steps.begin(), steps.end());
  return steps;
}

/// A damaged file is the user's input: HDF5's failures to read it (h5.hpp throws them as
/// std::runtime_error) become InputError, so that probe and compare exit 2 and not 1.
template <class Read>
auto as_input_error(Read read) -> decltype(read()) {
  try {
    return read();
  } catch (const InputError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());
  }
}

}  // namespace

ResultsReader::ResultsReader(const std::string& h5_path) : m_path(h5_path) {
  as_input_error([&] {
    h5::File file = open_results(m_path);
    require_layout(file);
    m_scene_text = file.read_string_attribute(file.id(), "scene");
    m_particles = read_particles(file);
    m_steps = read_step_numbers(file);
  });
}

namespace {

/// "steps/000007" after checking that step K is present.
std::string step_path(const std::string& file, const std::vector<int>& steps, int step) {
  if (!std::binary_search(steps.begin(), steps.end(), step)) {
    throw InputError("step " + std::to_string(step) + " is not in '" + file + "' (" + describe_steps(steps) +
                     ")");
  }
  return "steps/" + io::step_group_name(step);
}

}  // namespace

VectorXd ResultsReader::displacement(int step) const {
  const std::string group = step_path(m_path, m_steps, step);
  return as_input_error([&] {
    h5::File file = h5::File::open(m_path, false);
    const std::string dataset = group + "/displacement";
    require_shape(file, dataset, {static_cast<hsize_t>(m_particles.size()), 2});
    const std::vector<double> values = file.read_doubles(file.id(), dataset);
    return VectorXd(Eigen::Map<const VectorXd>(values.data(), static_cast<Eigen::Index>(values.size())));
  });
}

VectorXd ResultsReader::per_particle(int step, const std::string& name, const std::string& absent) const {
  const std::string group = step_path(m_path, m_steps, step);
  return as_input_error([&] {
    h5::File file = h5::File::open(m_path, false);
    const std::string dataset = group + "/" + name;
    if (!file.link_exists(file.id(), dataset))
      throw InputError("'" + m_path + "': step " + std::to_string(step) + " has no " + name + " (" + absent +
                       ")");
    require_shape(file, dataset, {static_cast<hsize_t>(m_particles.size())});
    const std::vector<double> values = file.read_doubles(file.id(), dataset);
    return VectorXd(Eigen::Map<const VectorXd>(values.data(), static_cast<Eigen::Index>(values.size())));
  });
}

VectorXd ResultsReader::damage(int step) const {
  return per_particle(step, "damage", "the scene has no failure section");
}

VectorXd ResultsReader::contact_state(int step) const {
  return per_particle(step, "contact_state", "the scene has no contact section");
}

VectorXd ResultsReader::held(int step) const {
  const std::string dataset = step_path(m_path, m_steps, step) + "/held";
  const bool present = as_input_error([&] {
    h5::File file = h5::File::open(m_path, false);
    return file.link_exists(file.id(), dataset);
  });
  return present ? per_particle(step, "held", "")
                 : VectorXd::Zero(static_cast<Eigen::Index>(m_particles.size()));
}

double ResultsReader::load_factor(int step) const {
  const std::string group_path = step_path(m_path, m_steps, step);
  return as_input_error([&] {
    h5::File file = h5::File::open(m_path, false);
    h5::Handle group = file.open_group(file.id(), group_path);
    return file.read_double_attribute(group, "load_factor");
  });
}

}  // namespace peristat
