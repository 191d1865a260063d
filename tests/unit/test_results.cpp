// Results files (docs/guide/results.md): layout, read-back, crash safety, probe_line.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>
#include <hdf5.h>  // the raw API, to check the contract paths independently of the reader
#include <nlohmann/json.hpp>
#include <pthread.h>
#include <signal.h>

#include "core/error.hpp"
#include "io/results.hpp"

namespace peristat {
namespace {

namespace fs = std::filesystem;

// ---- fixtures and helpers ------------------------------------------------------------

/// A fresh directory per test, removed afterwards.
class ResultsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    m_dir = fs::temp_directory_path() /
            ("peristat_test_results_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(m_dir);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(m_dir, ignored);
  }
  std::string dir() const { return m_dir.string(); }
  std::string path(const std::string& file) const { return (m_dir / file).string(); }

 private:
  fs::path m_dir;
};

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) {
    ++n;
  }
  return n;
}

/// 3 x 2 particles, spacing 0.5; two bodies; the last particle is fictitious.
ParticleTable small_table() {
  ParticleTable t;
  t.spacing = 0.5;
  t.body_names = {"plate", "punch"};
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 3; ++i) {
      t.position.emplace_back(0.25 + 0.5 * i, 0.25 + 0.5 * j);
      t.volume.push_back(0.25 + 0.01 * static_cast<double>(t.volume.size()));
      t.body.push_back(j);
      t.fictitious.push_back(0);
    }
  }
  t.fictitious.back() = 1;
  return t;
}

/// Fields of step k, distinct per step, entry and component.
struct StepFields {
  VectorXd displacement, damage, contact_force;
  std::vector<int> contact_state, held;
};

StepFields fields_of_step(int k, std::size_t n) {
  StepFields f;
  const auto m = static_cast<Eigen::Index>(n);
  f.displacement.resize(2 * m);
  f.damage.resize(m);
  f.contact_force.resize(2 * m);
  for (Eigen::Index i = 0; i < 2 * m; ++i) {
    f.displacement[i] = 100.0 * k + static_cast<double>(i) + 0.125;
    f.contact_force[i] = -1000.0 * k - static_cast<double>(i);
  }
  for (Eigen::Index i = 0; i < m; ++i) f.damage[i] = 0.01 * k * static_cast<double>(i);
  for (std::size_t i = 0; i < n; ++i) f.contact_state.push_back(static_cast<int>((i + k) % 3));
  for (std::size_t i = 0; i < n; ++i) f.held.push_back(i + 1 == n ? 1 : 0);
  return f;
}

/// Step k: damage and held flags from step 2 on, contact force on step 3 only.
StepRecord record_of_step(int k, const StepFields& f) {
  StepRecord r;
  r.index = k;
  r.load_factor = 0.25 * k;
  r.newton_iterations = 3 + k;
  r.active_set_iterations = k;
  r.residual_norm = 1e-10 * k;
  r.wall_seconds = 0.5 * k;
  r.displacement = &f.displacement;
  r.damage = k >= 2 ? &f.damage : nullptr;
  r.held = k >= 2 ? &f.held : nullptr;
  r.contact_force = k == 3 ? &f.contact_force : nullptr;
  r.contact_state = k == 3 ? &f.contact_state : nullptr;
  r.residual_history = {1.0, 1e-4 * k, 1e-10 * k};
  r.counts = {{"open", 1.0 * k}, {"stick", 2.0 * k}, {"broken_bonds", 10.0 * k}};
  r.timings = {{"assembly", 0.01 * k}, {"solve", 0.02 * k}};
  return r;
}

const char* const kScene = "name: small\ndiscretization:\n  spacing: 0.5\n";
const char* const kRunInfo = R"({"particles": 6, "solver": "newton"})";

// ---- raw HDF5 access, independent of the code under test -----------------------------

class RawFile {
 public:
  explicit RawFile(const std::string& path) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    m_id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  }
  ~RawFile() {
    if (m_id >= 0) H5Fclose(m_id);
  }
  RawFile(const RawFile&) = delete;
  RawFile& operator=(const RawFile&) = delete;
  hid_t id() const { return m_id; }

  bool exists(const std::string& link) const { return H5Lexists(m_id, link.c_str(), H5P_DEFAULT) > 0; }
  bool has_attribute(const std::string& object, const std::string& name) const {
    return H5Aexists_by_name(m_id, object.c_str(), name.c_str(), H5P_DEFAULT) > 0;
  }
  std::vector<hsize_t> dims(const std::string& dataset) const {
    const hid_t d = H5Dopen2(m_id, dataset.c_str(), H5P_DEFAULT);
    if (d < 0) return {};
    const hid_t s = H5Dget_space(d);
    std::vector<hsize_t> out(static_cast<std::size_t>(H5Sget_simple_extent_ndims(s)));
    H5Sget_simple_extent_dims(s, out.data(), nullptr);
    H5Sclose(s);
    H5Dclose(d);
    return out;
  }
  std::vector<double> doubles(const std::string& dataset) const {
    std::vector<hsize_t> shape = dims(dataset);
    std::size_t n = 1;
    for (hsize_t d : shape) n *= static_cast<std::size_t>(d);
    std::vector<double> out(n);
    const hid_t d = H5Dopen2(m_id, dataset.c_str(), H5P_DEFAULT);
    if (n > 0) H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data());
    H5Dclose(d);
    return out;
  }
  H5T_class_t dataset_class(const std::string& dataset) const {
    const hid_t d = H5Dopen2(m_id, dataset.c_str(), H5P_DEFAULT);
    const hid_t t = H5Dget_type(d);
    const H5T_class_t c = H5Tget_class(t);
    H5Tclose(t);
    H5Dclose(d);
    return c;
  }
  double attribute(const std::string& object, const std::string& name) const {
    double value = std::nan("");
    const hid_t a = H5Aopen_by_name(m_id, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0) return value;
    H5Aread(a, H5T_NATIVE_DOUBLE, &value);
    H5Aclose(a);
    return value;
  }
  /// Element count of an attribute's dataspace (1 for a scalar).
  hssize_t attribute_size(const std::string& object, const std::string& name) const {
    const hid_t a = H5Aopen_by_name(m_id, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0) return -1;
    const hid_t s = H5Aget_space(a);
    const hssize_t n = H5Sget_simple_extent_npoints(s);
    H5Sclose(s);
    H5Aclose(a);
    return n;
  }

 private:
  hid_t m_id = H5I_INVALID_HID;
};

/// Runs `action`, expects a std::runtime_error whose message contains every `needle`.
template <class Action>
void expect_error_naming(Action action, const std::vector<std::string>& needles) {
  try {
    action();
    ADD_FAILURE() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    for (const auto& needle : needles) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
          << "message '" << e.what() << "' does not mention '" << needle << "'";
    }
  }
}

void write_three_steps(ResultsWriter& writer, std::size_t n) {
  for (int k = 1; k <= 3; ++k) {
    const StepFields f = fields_of_step(k, n);
    writer.write_step(record_of_step(k, f));
  }
}

// ---- writer layout and read-back -----------------------------------------------------

TEST_F(ResultsTest, ReaderReadsBackEverythingWritten) {
  const ParticleTable table = small_table();
  {
    ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
    EXPECT_EQ(writer.h5_path(), path("small.h5"));
    write_three_steps(writer, table.size());
    writer.finish("completed", "all 3 steps converged");
  }
  const ResultsReader reader(path("small.h5"));
  EXPECT_EQ(reader.scene_text(), kScene);
  EXPECT_EQ(reader.steps(), (std::vector<int>{1, 2, 3}));
  const ParticleTable& p = reader.particles();
  ASSERT_EQ(p.size(), table.size());
  for (std::size_t i = 0; i < table.size(); ++i) {
    EXPECT_EQ(p.position[i], table.position[i]) << i;
    EXPECT_EQ(p.volume[i], table.volume[i]) << i;
    EXPECT_EQ(p.body[i], table.body[i]) << i;
    EXPECT_EQ(p.fictitious[i], table.fictitious[i]) << i;
  }
  EXPECT_EQ(p.spacing, table.spacing);
  EXPECT_EQ(p.body_names, table.body_names);
  for (int k = 1; k <= 3; ++k) {
    // Exact equality: HDF5 stores the IEEE doubles bit for bit.
    EXPECT_EQ(reader.displacement(k), fields_of_step(k, table.size()).displacement) << k;
    EXPECT_EQ(reader.load_factor(k), 0.25 * k);
  }
}

TEST_F(ResultsTest, HdfLayoutFollowsTheContract) {
  const ParticleTable table = small_table();
  {
    ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
    write_three_steps(writer, table.size());
  }
  const RawFile file(path("small.h5"));
  ASSERT_GE(file.id(), 0);
  EXPECT_TRUE(file.has_attribute("/", "scene"));
  EXPECT_EQ(file.attribute_size("/", "scene"), 1);
  EXPECT_EQ(file.dims("/particles/position"), (std::vector<hsize_t>{6, 2}));
  EXPECT_EQ(file.dims("/particles/volume"), (std::vector<hsize_t>{6}));
  EXPECT_EQ(file.dims("/particles/body"), (std::vector<hsize_t>{6}));
  EXPECT_EQ(file.dims("/particles/fictitious"), (std::vector<hsize_t>{6}));
  EXPECT_EQ(file.dataset_class("/particles/body"), H5T_INTEGER);
  EXPECT_EQ(file.dataset_class("/particles/fictitious"), H5T_INTEGER);
  // The XDMF's vertex cells: one per particle, so ParaView has cells to draw.
  EXPECT_EQ(file.dims("/particles/vertex"), (std::vector<hsize_t>{6}));
  EXPECT_EQ(file.dataset_class("/particles/vertex"), H5T_INTEGER);
  EXPECT_EQ(file.doubles("/particles/vertex"), (std::vector<double>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(file.attribute("/particles", "spacing"), 0.5);
  EXPECT_EQ(file.attribute_size("/particles", "body_names"), 2);
  EXPECT_EQ(file.doubles("/particles/position")[3], table.position[1].y());

  for (int k = 1; k <= 3; ++k) {
    const std::string g = "/steps/00000" + std::to_string(k);
    SCOPED_TRACE(g);
    ASSERT_TRUE(file.exists(g));
    const StepFields f = fields_of_step(k, table.size());
    EXPECT_EQ(file.dims(g + "/displacement"), (std::vector<hsize_t>{6, 2}));
    EXPECT_EQ(file.doubles(g + "/displacement")[5], f.displacement[5]);
    EXPECT_EQ(file.exists(g + "/damage"), k >= 2);
    if (k >= 2) {
      EXPECT_EQ(file.dims(g + "/damage"), (std::vector<hsize_t>{6}));
      EXPECT_EQ(file.doubles(g + "/held"), (std::vector<double>{0, 0, 0, 0, 0, 1}));
    }
    EXPECT_EQ(file.exists(g + "/held"), k >= 2);
    EXPECT_EQ(file.exists(g + "/contact_force"), k == 3);
    if (k == 3) {
      EXPECT_EQ(file.dims(g + "/contact_force"), (std::vector<hsize_t>{6, 2}));
      EXPECT_EQ(file.doubles(g + "/contact_force")[7], f.contact_force[7]);
      EXPECT_EQ(file.dims(g + "/contact_state"), (std::vector<hsize_t>{6}));
      EXPECT_EQ(file.doubles(g + "/contact_state"), (std::vector<double>{0, 1, 2, 0, 1, 2}));
    }
    EXPECT_EQ(file.exists(g + "/contact_state"), k == 3);
    EXPECT_EQ(file.doubles(g + "/residual_history"), (std::vector<double>{1.0, 1e-4 * k, 1e-10 * k}));
    EXPECT_EQ(file.attribute(g, "load_factor"), 0.25 * k);
    EXPECT_EQ(file.attribute(g, "newton_iterations"), 3 + k);
    EXPECT_EQ(file.attribute(g, "active_set_iterations"), k);
    EXPECT_EQ(file.attribute(g, "residual_norm"), 1e-10 * k);
    EXPECT_EQ(file.attribute(g, "wall_seconds"), 0.5 * k);
    EXPECT_EQ(file.attribute(g, "broken_bonds"), 10.0 * k);
    EXPECT_EQ(file.attribute(g, "time_solve"), 0.02 * k);
  }
  EXPECT_FALSE(file.exists("/steps/000004"));
  EXPECT_FALSE(fs::exists(path("small.h5.tmp")));
}

/// The keys of a JSON object, in file order.
std::vector<std::string> keys_of(const nlohmann::ordered_json& object) {
  std::vector<std::string> keys;
  for (const auto& item : object.items()) keys.push_back(item.key());
  return keys;
}

TEST_F(ResultsTest, SummaryJsonHoldsStepsStatusAndEscapes) {
  using nlohmann::ordered_json;
  const ParticleTable table = small_table();
  ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
  ordered_json summary = ordered_json::parse(read_text(path("summary.json")));
  EXPECT_EQ(summary["status"], "running") << summary;
  EXPECT_EQ(summary["steps"], ordered_json::array()) << summary;

  write_three_steps(writer, table.size());
  StepFields f = fields_of_step(4, table.size());
  StepRecord odd = record_of_step(4, f);
  odd.residual_history = {1.0, std::nan(""), INFINITY};
  writer.write_step(odd);
  writer.finish("no_convergence", "step 5: \"stalled\"\n\tsee log");

  const std::string text = read_text(path("summary.json"));
  summary = ordered_json::parse(text);
  EXPECT_EQ(keys_of(summary),
            (std::vector<std::string>{"scene", "status", "message", "warnings", "program", "run", "steps"}));
  EXPECT_EQ(summary["scene"], "small");
  EXPECT_EQ(summary["status"], "no_convergence");
  EXPECT_EQ(summary["message"], "step 5: \"stalled\"\n\tsee log");
  EXPECT_NE(text.find(R"("message": "step 5: \"stalled\"\n\tsee log")"), std::string::npos) << text;
  EXPECT_EQ(summary["run"], ordered_json::parse(kRunInfo)) << "run info is stored as given";
  ASSERT_EQ(summary["steps"].size(), 4u) << text;
  for (int k = 1; k <= 4; ++k) {
    const ordered_json& step = summary["steps"][k - 1];
    EXPECT_EQ(keys_of(step), (std::vector<std::string>{
                                 "step", "load_factor", "newton_iterations", "active_set_iterations",
                                 "residual_norm", "wall_seconds", "residual_history", "counts", "timings"}));
    EXPECT_TRUE(step["step"].is_number_integer());
    EXPECT_EQ(step["step"], k);
    EXPECT_EQ(step["newton_iterations"], 3 + k);
    EXPECT_EQ(step["load_factor"].get<double>(), 0.25 * k);
    // Integral values are written as integers (counts read as ints, as they always did).
    EXPECT_TRUE(step["counts"]["broken_bonds"].is_number_integer()) << step["counts"];
    EXPECT_EQ(step["load_factor"].is_number_integer(), k == 4) << step["load_factor"];
    // Doubles round-trip exactly (1e-10 * 3 is 3.0000000000000003e-10).
    EXPECT_EQ(step["residual_norm"].get<double>(), 1e-10 * k);
    EXPECT_EQ(step["counts"]["broken_bonds"].get<double>(), 10.0 * k);
    EXPECT_EQ(step["timings"]["assembly"].get<double>(), 0.01 * k);
  }
  EXPECT_EQ(summary["steps"][1]["residual_history"], (ordered_json{1.0, 1e-4 * 2, 1e-10 * 2}));
  EXPECT_EQ(summary["steps"][3]["residual_history"], (ordered_json{1.0, nullptr, nullptr}))
      << "NaN and infinity are written as null";
  EXPECT_NE(text.find("\n  \"scene\": \"small\",\n"), std::string::npos) << "pretty-printed";
  EXPECT_EQ(text.substr(text.size() - 2), "}\n");
  EXPECT_FALSE(fs::exists(path("summary.json.tmp")));
}

TEST_F(ResultsTest, RunInfoIsAJsonObjectOrBlank) {
  const ParticleTable table = small_table();
  {
    ResultsWriter writer(dir(), "small", kScene, table, " \n");
    EXPECT_TRUE(nlohmann::ordered_json::parse(read_text(path("summary.json")))["run"].is_null());
  }
  EXPECT_THROW(ResultsWriter(dir(), "small", kScene, table, "[1, 2]"), std::invalid_argument);
  EXPECT_THROW(ResultsWriter(dir(), "small", kScene, table, "{\"particles\": "), std::invalid_argument);
}

TEST_F(ResultsTest, XdmfDescribesEveryStep) {
  const ParticleTable table = small_table();
  {
    ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
    // Before the first step: the reference configuration alone (ParaView's reader
    // crashes on an empty temporal collection).
    const std::string initial = read_text(path("small.xdmf"));
    EXPECT_EQ(count_of(initial, "Temporal"), 0u);
    EXPECT_EQ(count_of(initial, "<Grid Name=\"reference\""), 1u);
    EXPECT_EQ(count_of(initial, "small.h5:/particles/position"), 1u);
    write_three_steps(writer, table.size());
  }
  const std::string xdmf = read_text(path("small.xdmf"));
  EXPECT_EQ(count_of(xdmf, "<Grid Name=\"step_"), 3u);
  EXPECT_EQ(count_of(xdmf, "CollectionType=\"Temporal\""), 1u);
  EXPECT_EQ(count_of(xdmf, "TopologyType=\"Polyvertex\" NumberOfElements=\"6\""), 3u);
  EXPECT_EQ(count_of(xdmf, "small.h5:/particles/position"), 3u) << "relative file name";
  EXPECT_EQ(count_of(xdmf, "small.h5:/particles/vertex</DataItem>\n        </Topology>"), 3u)
      << "every grid's Polyvertex topology has its connectivity";
  for (int k = 1; k <= 3; ++k) {
    const std::string g = "small.h5:/steps/00000" + std::to_string(k);
    EXPECT_EQ(count_of(xdmf, g + "/displacement"), 1u);
    EXPECT_EQ(count_of(xdmf, g + "/damage"), k >= 2 ? 1u : 0u);
    EXPECT_EQ(count_of(xdmf, g + "/held"), k >= 2 ? 1u : 0u);
    EXPECT_EQ(count_of(xdmf, g + "/contact_force"), k == 3 ? 1u : 0u);
    EXPECT_EQ(count_of(xdmf, g + "/contact_state"), k == 3 ? 1u : 0u);
  }
  EXPECT_NE(xdmf.find("<Time Value=\"0.75\"/>"), std::string::npos);
  // N x 2 vectors: ParaView's XDMF Reader pads them to 3 components for Warp By Vector.
  EXPECT_EQ(count_of(xdmf, "AttributeType=\"Vector\""), 4u);
  EXPECT_EQ(count_of(xdmf, "<Grid"), count_of(xdmf, "</Grid>"));
  EXPECT_EQ(count_of(xdmf, "<Attribute"), count_of(xdmf, "</Attribute>"));
}

// ---- crash safety --------------------------------------------------------------------

TEST_F(ResultsTest, SigkillAfterTwoStepsLeavesTwoValidSteps) {
  const ParticleTable table = small_table();
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    try {
      ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
      for (int k = 1; k <= 2; ++k) {
        const StepFields f = fields_of_step(k, table.size());
        writer.write_step(record_of_step(k, f));
      }
      ::raise(SIGKILL);
    } catch (...) {
      ::_exit(3);
    }
    ::_exit(4);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status)) << "child exited with " << WEXITSTATUS(status);
  ASSERT_EQ(WTERMSIG(status), SIGKILL);

  const ResultsReader reader(path("small.h5"));
  EXPECT_EQ(reader.steps(), (std::vector<int>{1, 2}));
  EXPECT_EQ(reader.displacement(1), fields_of_step(1, table.size()).displacement);
  EXPECT_EQ(reader.displacement(2), fields_of_step(2, table.size()).displacement);
  EXPECT_EQ(reader.load_factor(2), 0.5);

  const std::string summary = read_text(path("summary.json"));
  const auto parsed = nlohmann::ordered_json::parse(summary);
  EXPECT_EQ(parsed["steps"].size(), 2u) << summary;
  EXPECT_EQ(parsed["status"], "running");
  EXPECT_EQ(summary.substr(summary.size() - 2), "}\n");
  EXPECT_EQ(count_of(read_text(path("small.xdmf")), "<Grid Name=\"step_"), 2u);
}

TEST_F(ResultsTest, WriteStepRestoresTheSignalMask) {
  const ParticleTable table = small_table();
  ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
  sigset_t before, after;
  ASSERT_EQ(pthread_sigmask(SIG_SETMASK, nullptr, &before), 0);
  const StepFields f = fields_of_step(1, table.size());
  writer.write_step(record_of_step(1, f));
  ASSERT_EQ(pthread_sigmask(SIG_SETMASK, nullptr, &after), 0);
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    EXPECT_EQ(sigismember(&before, sig), sigismember(&after, sig)) << sig;
  }
}

TEST_F(ResultsTest, AViewerHoldingTheFileOpenDoesNotStopTheWriter) {
  const ParticleTable table = small_table();
  ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
  // Another process (ParaView, h5py, peristat probe) keeps the file open read-only,
  // which by default takes HDF5's shared file lock.
  int opened[2], release[2];
  ASSERT_EQ(::pipe(opened), 0);
  ASSERT_EQ(::pipe(release), 0);
  const pid_t viewer = ::fork();
  ASSERT_GE(viewer, 0);
  if (viewer == 0) {
    const RawFile file(path("small.h5"));
    const char ok = file.id() >= 0 ? 'y' : 'n';
    char ignored = 0;
    const bool sent = ::write(opened[1], &ok, 1) == 1;
    const bool waited = ::read(release[0], &ignored, 1) >= 0;
    ::_exit(sent && waited ? 0 : 1);
  }
  char ok = 0;
  ASSERT_EQ(::read(opened[0], &ok, 1), 1);
  EXPECT_EQ(ok, 'y');
  const StepFields f = fields_of_step(1, table.size());
  EXPECT_NO_THROW(writer.write_step(record_of_step(1, f)));
  ASSERT_EQ(::write(release[1], "x", 1), 1);
  int status = 0;
  ASSERT_EQ(::waitpid(viewer, &status, 0), viewer);
  for (const int fd : {opened[0], opened[1], release[0], release[1]}) ::close(fd);
  EXPECT_EQ(ResultsReader(path("small.h5")).steps(), (std::vector<int>{1}));
}

// ---- probe_line ----------------------------------------------------------------------

/// u(x) = A x + c, affine so that bilinear interpolation reproduces it exactly.
Vec2 affine(const Vec2& x) {
  return Vec2(1e-3 + 2e-3 * x.x() - 5e-4 * x.y(), -2e-3 + 1e-3 * x.x() + 3e-3 * x.y());
}

/// Body 0: 8 x 5 particles from (0.25, 0.25), spacing 0.5, with a fictitious column at
/// x = -0.25 carrying a wild displacement (it must be ignored). Body 1: 4 x 4 particles on
/// a lattice whose origin is not aligned with body 0's.
ParticleTable probe_table() {
  ParticleTable t;
  t.spacing = 0.5;
  t.body_names = {"block", "shifted"};
  auto add = [&t](double x, double y, int body, int fictitious) {
    t.position.emplace_back(x, y);
    t.volume.push_back(0.25);
    t.body.push_back(body);
    t.fictitious.push_back(fictitious);
  };
  for (int j = 0; j < 5; ++j) {
    add(-0.25, 0.25 + 0.5 * j, 0, 1);
    for (int i = 0; i < 8; ++i) add(0.25 + 0.5 * i, 0.25 + 0.5 * j, 0, 0);
  }
  for (int j = 0; j < 4; ++j) {
    for (int i = 0; i < 4; ++i) add(10.1 + 0.5 * i, 0.37 + 0.5 * j, 1, 0);
  }
  return t;
}

VectorXd affine_field(const ParticleTable& t) {
  VectorXd u(2 * static_cast<Eigen::Index>(t.size()));
  for (std::size_t i = 0; i < t.size(); ++i) {
    const Vec2 v = t.fictitious[i] != 0 ? Vec2(1e6, -1e6) : affine(t.position[i]);
    u[2 * static_cast<Eigen::Index>(i)] = v.x();
    u[2 * static_cast<Eigen::Index>(i) + 1] = v.y();
  }
  return u;
}

/// DIR/<name>.h5 holding `table` and one step of its affine field.
void write_affine_step(const std::string& dir, const std::string& name, const ParticleTable& table) {
  const VectorXd u = affine_field(table);
  ResultsWriter writer(dir, name, "name: " + name + "\n", table, "{}");
  StepRecord r;
  r.index = 1;
  r.load_factor = 1.0;
  r.displacement = &u;
  writer.write_step(r);
}

class ProbeTest : public ResultsTest {
 protected:
  void SetUp() override {
    ResultsTest::SetUp();
    write_affine_step(dir(), "probe", probe_table());
  }
  ResultsReader reader() const { return ResultsReader(path("probe.h5")); }
};

void expect_affine(const std::vector<ProbeSample>& samples) {
  for (const ProbeSample& s : samples) {
    const Vec2 exact = affine(Vec2(s.x, s.y));
    // Bilinear interpolation is exact for affine fields: only rounding remains.
    EXPECT_NEAR(s.ux, exact.x(), 1e-12 * std::abs(exact.x())) << "at " << s.x << ", " << s.y;
    EXPECT_NEAR(s.uy, exact.y(), 1e-12 * std::abs(exact.y())) << "at " << s.x << ", " << s.y;
  }
}

TEST_F(ProbeTest, ReproducesAnAffineFieldExactly) {
  const ResultsReader results = reader();
  const Vec2 a(0.3, 0.4), b(3.6, 2.2);
  const std::vector<ProbeSample> samples = probe_line(results, 1, a, b, 41);
  ASSERT_EQ(samples.size(), 41u);
  expect_affine(samples);
  EXPECT_EQ(samples.front().s, 0.0);
  EXPECT_EQ(samples.front().x, a.x());
  EXPECT_EQ(samples.back().x, b.x());
  EXPECT_EQ(samples.back().y, b.y());
  EXPECT_DOUBLE_EQ(samples.back().s, (b - a).norm());
  EXPECT_DOUBLE_EQ(samples[10].s, 0.25 * (b - a).norm());

  // Next to the fictitious column, and along particle rows and columns.
  expect_affine(probe_line(results, 1, Vec2(0.25, 0.3), Vec2(0.9, 0.3), 14));
  expect_affine(probe_line(results, 1, Vec2(1.25, 0.25), Vec2(1.25, 2.25), 9));
  // In the body whose lattice is offset from the first one.
  expect_affine(probe_line(results, 1, Vec2(10.2, 0.5), Vec2(11.5, 1.8), 17));
  // One point is the start point.
  const std::vector<ProbeSample> one = probe_line(results, 1, a, b, 1);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one.front().x, a.x());
  expect_affine(one);
}

TEST_F(ProbeTest, NanAwayFromEveryBody) {
  const ResultsReader results = reader();
  for (const ProbeSample& s : probe_line(results, 1, Vec2(20, 20), Vec2(30, -5), 11)) {
    EXPECT_TRUE(std::isnan(s.ux) && std::isnan(s.uy)) << s.x << ", " << s.y;
  }
  // A line leaving the block: finite within one spacing of a particle, NaN beyond.
  const std::vector<ProbeSample> line = probe_line(results, 1, Vec2(2.0, 1.0), Vec2(6.0, 1.0), 9);
  for (const ProbeSample& s : line) {
    const bool inside = s.x <= 3.75 + 0.5;
    EXPECT_EQ(std::isfinite(s.ux), inside) << s.x;
    EXPECT_EQ(std::isfinite(s.uy), inside) << s.x;
  }
  // Beyond the last particle but within a spacing: blended from present corners.
  EXPECT_TRUE(std::isfinite(line[4].ux));
  EXPECT_EQ(line[4].x, 4.0);
}

TEST_F(ProbeTest, IsDeterministicAndChecksItsArguments) {
  const ResultsReader results = reader();
  const auto first = probe_line(results, 1, Vec2(-1, -1), Vec2(5, 3), 57);
  const auto second = probe_line(results, 1, Vec2(-1, -1), Vec2(5, 3), 57);
  ASSERT_EQ(first.size(), second.size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    EXPECT_TRUE((first[i].ux == second[i].ux) || (std::isnan(first[i].ux) && std::isnan(second[i].ux)));
  }
  EXPECT_THROW(probe_line(results, 1, Vec2(0, 0), Vec2(1, 1), 0), std::runtime_error);
  expect_error_naming([&] { probe_line(results, 2, Vec2(0, 0), Vec2(1, 1), 5); },
                      {path("probe.h5"), "step 2"});
}

// Found by tests/fuzz (crashes/results/crash-b1f207d2...): a damaged file's positions, or a
// probe point, far from the particles in units of the spacing were cast to int64 (UB).
TEST_F(ProbeTest, FarPointsAreNanAndFarParticlesAnInputError) {
  const ResultsReader results = reader();
  for (const ProbeSample& s : probe_line(results, 1, Vec2(1e300, -1e300), Vec2(1e20, 2.0), 3)) {
    EXPECT_TRUE(std::isnan(s.ux) && std::isnan(s.uy)) << s.x << ", " << s.y;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(std::isnan(probe_line(results, 1, Vec2(nan, 0), Vec2(nan, 1), 2).front().ux));

  ParticleTable far = probe_table();
  far.spacing = 0.5;
  far.position[3] = Vec2(1e300, 0.0);
  write_affine_step(dir(), "far", far);
  const ResultsReader damaged(path("far.h5"));
  EXPECT_THROW(probe_line(damaged, 1, Vec2(0, 0), Vec2(1, 1), 3), InputError);
}

// ---- reader and writer errors --------------------------------------------------------

TEST_F(ResultsTest, ReaderErrorsNameTheFile) {
  fs::create_directories(dir());
  const std::string missing = path("missing.h5");
  expect_error_naming([&] { ResultsReader r(missing); }, {missing});

  const std::string text = path("text.h5");
  std::ofstream(text) << "not hdf5\n";
  expect_error_naming([&] { ResultsReader r(text); }, {text});

  const std::string foreign = path("foreign.h5");
  {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    const hid_t f = H5Fcreate(foreign.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    const hsize_t n = 3;
    const double values[3] = {1, 2, 3};
    const hid_t s = H5Screate_simple(1, &n, nullptr);
    const hid_t d = H5Dcreate2(f, "foo", H5T_IEEE_F64LE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values);
    H5Dclose(d);
    H5Sclose(s);
    H5Fclose(f);
  }
  expect_error_naming([&] { ResultsReader r(foreign); }, {foreign, "not a peristat"});

  const ParticleTable table = small_table();
  {
    ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
    write_three_steps(writer, table.size());
  }
  const ResultsReader reader(path("small.h5"));
  expect_error_naming([&] { (void)reader.displacement(7); }, {path("small.h5"), "step 7"});
  expect_error_naming([&] { (void)reader.load_factor(0); }, {path("small.h5"), "step 0"});
}

/// A file with the layout's four /particles datasets of `n` particles, chunked and never
/// written (HDF5 reads them as zeros), one step, and `displacement` of step 1 a group.
void write_unwritten_particles(const std::string& file, hsize_t n) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t f = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t scalar = H5Screate(H5S_SCALAR);
  const hid_t text = H5Tcopy(H5T_C_S1);
  H5Tset_size(text, 8);
  const hid_t scene = H5Acreate2(f, "scene", text, scalar, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(scene, text, "name: x");
  const hid_t particles = H5Gcreate2(f, "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  for (const char* name : {"position", "volume", "body", "fictitious"}) {
    const bool pairs = std::string(name) == "position";
    const hsize_t dims[2] = {n, 2}, chunk[2] = {std::min<hsize_t>(n, 1024), pairs ? 2u : 1u};
    const hid_t space = H5Screate_simple(pairs ? 2 : 1, dims, nullptr);
    const hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(plist, pairs ? 2 : 1, chunk);
    H5Dclose(H5Dcreate2(particles, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, plist, H5P_DEFAULT));
    H5Pclose(plist);
    H5Sclose(space);
  }
  const hid_t steps = H5Gcreate2(f, "steps", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t step = H5Gcreate2(steps, "000001", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Gclose(H5Gcreate2(step, "displacement", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  for (const hid_t g : {step, steps, particles}) H5Gclose(g);
  H5Aclose(scene);
  H5Tclose(text);
  H5Sclose(scalar);
  H5Fclose(f);
}

// Found by tests/fuzz: a damaged file is the user's input wherever the reader meets the damage
// (HDF5's errors after the constructor made probe and compare exit 1, internal error), and
// a shape is not trusted before the buffer for it is allocated.
TEST_F(ResultsTest, DamagedFilesAreInputErrors) {
  fs::create_directories(dir());
  const std::string huge = path("huge.h5");
  write_unwritten_particles(huge, hsize_t{1} << 40);  // 8 TiB of positions in a few kB
  expect_error_naming([&] { ResultsReader r(huge); }, {huge, "particles/position", "is the file damaged?"});
  EXPECT_THROW(ResultsReader r(huge), InputError);

  const std::string odd = path("odd.h5");
  write_unwritten_particles(odd, 3);
  const ResultsReader reader(odd);
  EXPECT_EQ(reader.particles().size(), 3u);
  EXPECT_EQ(reader.steps(), (std::vector<int>{1}));
  EXPECT_THROW((void)reader.displacement(1), InputError);
  EXPECT_THROW((void)reader.load_factor(1), InputError);
}

TEST_F(ResultsTest, WriterRejectsInconsistentInput) {
  const ParticleTable table = small_table();
  ParticleTable ragged = table;
  ragged.volume.pop_back();
  EXPECT_THROW(ResultsWriter(dir(), "small", kScene, ragged, kRunInfo), std::invalid_argument);

  ResultsWriter writer(dir(), "small", kScene, table, kRunInfo);
  const StepFields f = fields_of_step(1, table.size());
  StepRecord r = record_of_step(1, f);
  const VectorXd short_u = VectorXd::Zero(3);
  r.displacement = &short_u;
  EXPECT_THROW(writer.write_step(r), std::invalid_argument);
  r = record_of_step(1, f);
  r.counts["load_factor"] = 1.0;  // would overwrite a contract attribute
  EXPECT_THROW(writer.write_step(r), std::invalid_argument);
  writer.write_step(record_of_step(1, f));
  EXPECT_THROW(writer.write_step(record_of_step(1, f)), std::invalid_argument);
  EXPECT_EQ(ResultsReader(path("small.h5")).steps(), (std::vector<int>{1}));
  EXPECT_THROW(writer.finish("done", ""), std::invalid_argument);

  // A directory that cannot be created: its parent is a regular file.
  const std::string blocked = path("plain_file");
  std::ofstream(blocked) << "x";
  expect_error_naming([&] { ResultsWriter w(blocked + "/sub", "small", kScene, table, kRunInfo); },
                      {blocked + "/sub"});
}

}  // namespace
}  // namespace peristat
