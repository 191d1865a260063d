// The distributed linear algebra (issue 16; docs/guide/distributed.md): a run on two MPI
// ranks with solver.linear=belos gives the serial run's answer. Each test runs the scene
// twice, serially with the case's own solver and under `mpirun -n 2` with belos (its defaults:
// a matrix-free tangent, MueLu on the bond matrix), and compares the final steps with
// `peristat compare`. 1e-8 relative L2 is the bound: both runs stop at Newton's
// residual tolerance (rtol 1e-10 of the force scale) with Krylov solves to 1e-10, so they
// may differ by a few times 1e-10 of the displacement; measured differences are 2e-12 to
// 8e-12 (docs/guide/distributed.md, "Contact on the parts" and "Same answers as one process?").
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "io/results.hpp"
#include "support/cli.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

namespace fs = std::filesystem;

struct Pair {
  fs::path dir;
  test::CliResult serial, distributed;
  std::string name;  ///< the scene's name (the results file's stem)
  fs::path h5(const std::string& which) const { return dir / which / (name + ".h5"); }
};

/// Runs cases/<c>/scene.yaml with `extra` serially and on two ranks with belos.
Pair run_both(const std::string& c, const std::string& name, const std::string& extra) {
  Pair p;
  p.name = name;
  // A directory per scene and settings: tests of one scene may run at once (ctest -j).
  p.dir = test::fresh_directory("distributed_" + name + "_" +
                                std::to_string(std::hash<std::string>{}(extra) % 1000000));
  const std::string scene = std::string(PERISTAT_SOURCE_DIR) + "/cases/" + c + "/scene.yaml";
  p.serial = test::run_cli("run " + scene + " --quiet --out " + (p.dir / "serial").string() + extra);
  p.distributed = test::run_mpi(
      2, "run " + scene + " --quiet --out " + (p.dir / "mpi").string() + extra + " --set solver.linear=belos");
  return p;
}

/// The names of the files in `dir`, sorted.
std::set<std::string> listing(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

double relative_difference(const Pair& p) {
  const test::CliResult c =
      test::run_cli("compare " + p.h5("mpi").string() + " " + p.h5("serial").string() + " --json");
  EXPECT_EQ(c.exit_code, 0) << c.err;
  return test::json_number(c.out, "relative_l2");
}

/// `bonds`: the families each rank held (a part: some only).
void expect_same_answer(const Pair& p, const std::string& bonds = "partitioned") {
  ASSERT_EQ(p.serial.exit_code, 0) << p.serial.err;
  ASSERT_EQ(p.distributed.exit_code, 0) << p.distributed.out << p.distributed.err;
  const double d = relative_difference(p);
  EXPECT_LE(d, 1e-8) << "the two-rank answer differs from the serial one";
  const nlohmann::json summary = test::read_json(p.dir / "mpi" / "summary.json");
  EXPECT_EQ(summary["status"], "completed");
  EXPECT_TRUE(summary["run"].contains("partition")) << "the run records how its rows were split";
  EXPECT_EQ(summary["run"]["bonds_held"], bonds);
  if (bonds == "partitioned") {
    // The bonds a rank holds: fewer than the model's, and at least half of them (the largest part).
    const long long held = summary["run"]["largest_rank_bonds"],
                    all = 2 * summary["run"]["bonds"].get<long long>();
    EXPECT_LT(held, all);
    EXPECT_GE(2 * held, all);
  }
  EXPECT_NE(summary["run"].dump().find("belos"), std::string::npos) << "the run names its linear solver";
  EXPECT_EQ(listing(p.dir / "mpi"), listing(p.dir / "serial")) << "the files of a serial run, no more";
}

TEST(Distributed, TensionPlateOnTwoRanksEqualsSerial) {
  // Under mpirun every run is on the ranks' parts of the model: the results rank 0 writes are
  // gathered from them by global id, particle for particle.
  const Pair p = run_both("tension_plate", "tension_plate", " --set discretization.spacing=2e-3");
  expect_same_answer(p);
  const nlohmann::json mpi = test::read_json(p.dir / "mpi" / "summary.json"),
                       serial = test::read_json(p.dir / "serial" / "summary.json");
  EXPECT_EQ(mpi["run"]["model"], "part");
  // Each part holds its own particles and their neighbours: more than half, fewer than all.
  const long long held = mpi["run"]["largest_rank_particles"], all = mpi["run"]["particles"];
  EXPECT_LT(held, all);
  EXPECT_GT(2 * held, all);
  // The whole model's counts, summed over the parts' own particles.
  for (const char* key : {"particles", "fictitious", "bonds", "unknowns"})
    EXPECT_EQ(mpi["run"][key], serial["run"][key]) << key;
  // The reactions are sums over the ranks' own particles: the serial ones within 1e-8 of the
  // grip force (both stop at Newton's rtol 1e-10 of the force scale).
  const nlohmann::json &a = mpi["steps"].back()["counts"], &b = serial["steps"].back()["counts"];
  const double grip = std::abs(b["reaction_1_x"].get<double>());
  EXPECT_GT(grip, 0.0);
  for (const char* key : {"reaction_0_x", "reaction_0_y", "reaction_1_x", "reaction_1_y", "reaction_2_y"})
    EXPECT_LE(std::abs(a[key].get<double>() - b[key].get<double>()), 1e-8 * grip) << key;
  EXPECT_LE(std::abs(a["energy_strain"].get<double>() - b["energy_strain"].get<double>()),
            1e-8 * b["energy_strain"].get<double>());
}

// Every particle of the results file, the fictitious ones included, as the serial run wrote
// it. A mirror ghost's displacement is its source's image, right only on a rank that holds the
// source's: rank 0 gathers each particle's row from its owner, so the ghost is owned with its
// source (LatticePartition::owner()). Before that, 4 ranks wrote 0 for 68 of the 800 ghosts of this plate
// (3 ranks: 38); `peristat compare` reads the real particles only and saw no difference.
// Tolerance: 1e-8 of the largest displacement, expect_same_answer's bound.
TEST(Distributed, EveryParticleOnFourRanksIsWrittenAsSerial) {
  const fs::path dir = test::fresh_directory("distributed_every_particle");
  const std::string scene = std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml";
  const std::string extra = " --quiet --set discretization.spacing=2e-3";
  const test::CliResult serial = test::run_cli("run " + scene + " --out " + (dir / "serial").string() + extra);
  const test::CliResult mpi = test::run_mpi(4, "run " + scene + " --out " + (dir / "mpi").string() + extra);
  ASSERT_EQ(serial.exit_code, 0) << serial.err;
  ASSERT_EQ(mpi.exit_code, 0) << mpi.out << mpi.err;
  const ResultsReader a((dir / "serial" / "tension_plate.h5").string()), b((dir / "mpi" / "tension_plate.h5").string());
  ASSERT_EQ(a.steps(), b.steps());
  const std::vector<int>& fictitious = a.particles().fictitious;
  ASSERT_GT(std::count(fictitious.begin(), fictitious.end(), 1), 0) << "the plate has mirror ghosts";
  for (const int step : a.steps()) {
    const VectorXd u = a.displacement(step), v = b.displacement(step);
    ASSERT_EQ(u.size(), v.size());
    const double scale = u.cwiseAbs().maxCoeff();
    int off = 0;
    for (Index k = 0; k < u.size(); ++k) off += std::abs(u[k] - v[k]) > 1e-8 * scale;
    EXPECT_EQ(off, 0) << "step " << step << ": components written otherwise than serially";
  }
}

// Contact on the parts (every run under mpirun, docs/guide/distributed.md): each rank
// holds the pairs that touch its own particles, oriented and ordered as in the whole model,
// owns those whose first end it owns, and reduces the counts, the signature and the checks
// over the ranks. Cases 4.1 (an interface between two plates, friction 0.8, partner
// searches as they slide) and 4.3 (a closed pre-crack, friction 0.8) on two ranks against the
// serial run: the displacement within 1e-8 (measured 8.1e-12 and 7.6e-12), and at every step
// the same counts of candidates, stick and slip pairs, and the contact state of every particle.
void expect_contact_on_parts_as_serial(const std::string& c, const std::string& dx,
                                       const std::string& extra = "") {
  SCOPED_TRACE(c + extra);
  const Pair p =
      run_both(c, c, " --set discretization.spacing=" + dx + extra);
  expect_same_answer(p);
  const nlohmann::json mpi = test::read_json(p.dir / "mpi" / "summary.json"),
                       serial = test::read_json(p.dir / "serial" / "summary.json");
  EXPECT_EQ(mpi["run"]["model"], "part");
  ASSERT_EQ(mpi["steps"].size(), serial["steps"].size());
  for (std::size_t k = 0; k < serial["steps"].size(); ++k)
    for (const char* key : {"contact_candidates", "contact_open", "contact_stick", "contact_slip"})
      EXPECT_EQ(mpi["steps"][k]["counts"][key], serial["steps"][k]["counts"][key])
          << key << ", step " << k + 1;
  const ResultsReader a(p.h5("mpi").string()), b(p.h5("serial").string());
  for (const int step : b.steps()) {
    const VectorXd sa = a.contact_state(step), sb = b.contact_state(step);
    ASSERT_EQ(sa.size(), sb.size());
    EXPECT_TRUE((sa.array() == sb.array()).all()) << "contact states, step " << step;
    EXPECT_GT(sb.maxCoeff(), 0.0) << "pairs must close for this test to mean anything";
  }
}

TEST(Distributed, ContactOnThePartsEqualsSerial) {
  expect_contact_on_parts_as_serial("paper_4_1_sliding_plates", "1e-3");
  expect_contact_on_parts_as_serial("paper_4_3_precracked_plate", "0.02");
  // Exact enforcement: the multipliers of the pairs a part holds are updated alike on every
  // rank that holds them; the largest violation and the decision are every rank's.
  expect_contact_on_parts_as_serial("paper_4_3_precracked_plate", "0.02", " --set contact.enforcement=exact");
}

// Large sliding on the parts: case 4.1's plates at dx = 1 mm with the left one pulled up by
// 6 mm in 12 steps (friction 0.3). The partner searches add pairs as the faces slide. On two
// ranks RCB cuts along the interface, and the slide stays within each part (its ring holds
// the other plate's particles along the whole height). On four ranks a cut across the height
// separates face particles from partners 6 mm away: the parts must grow (PartsOutgrown, at
// least once) and the run go on. Either way: the serial answer within 1e-8 (the bound of every
// distributed comparison: rounding differs with the ranks' sums, measured 1e-12 to 1e-11) and
// the same candidates at every step, so no pair was missed. The penalty law, as when the test
// was written: exact enforcement (the default) makes the serial run alone take minutes here.
std::string slide_scene(const fs::path& dir) {
  const fs::path path = dir / "large_slide.yaml";
  std::ofstream(path) << test::large_slide_yaml("6.0e-3", "friction: 0.3\n  enforcement: penalty");
  return path.string();
}

TEST(Distributed, LargeSlidingOnThePartsGrowsThePartsAndFindsThePartners) {
  const fs::path dir = test::fresh_directory("distributed_part_slide");
  const std::string scene = slide_scene(dir);
  const test::CliResult serial =
      test::run_cli("run " + scene + " --quiet --out " + (dir / "serial").string());
  ASSERT_EQ(serial.exit_code, 0) << serial.err;
  const nlohmann::json s = test::read_json(dir / "serial" / "summary.json");
  ASSERT_EQ(s["steps"].size(), 12u);
  const auto candidates = [](const nlohmann::json& j, std::size_t k) {
    return j["steps"][k]["counts"]["contact_candidates"].get<long long>();
  };
  EXPECT_GT(candidates(s, 11), candidates(s, 0))
      << "the searches must add pairs for this test to mean anything";
  for (const int ranks : {2, 4}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const fs::path out = dir / ("ranks" + std::to_string(ranks));
    const test::CliResult r = test::run_mpi(ranks, "run " + scene + " --out " + out.string());  // defaults
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    const nlohmann::json t = test::read_json(out / "summary.json");
    EXPECT_EQ(t["run"]["model"], "part");
    ASSERT_EQ(t["steps"].size(), 12u);
    for (std::size_t k = 0; k < 12; ++k) EXPECT_EQ(candidates(t, k), candidates(s, k)) << "step " << k + 1;
    if (ranks == 4) {
      ASSERT_TRUE(t["run"].contains("part_regrowths")) << "the cut across the height must make the parts grow";
      EXPECT_GE(t["run"]["part_regrowths"].get<int>(), 1);
      EXPECT_NE(r.out.find("the parts take in"), std::string::npos) << r.out;
    }
    const test::CliResult cmp = test::run_cli("compare " + (out / "large_slide.h5").string() + " " +
                                              (dir / "serial" / "large_slide.h5").string() + " --json");
    ASSERT_EQ(cmp.exit_code, 0) << cmp.err;
    EXPECT_LE(test::json_number(cmp.out, "relative_l2"), 1e-8);
  }
}

/// Stops `c` inside the write of step `kill` (its checkpoint holds the step before) on `first`
/// ranks and resumes it on `then` (1: one process), for each pair; each must end within 1e-10
/// of the uninterrupted run on two ranks.
void expect_resumes_on_parts(const std::string& c, const std::string& options, int steps, int kill) {
  SCOPED_TRACE(c);
  const std::string scene = std::string(PERISTAT_SOURCE_DIR) + "/cases/" + c + "/scene.yaml";
  const fs::path reference = test::fresh_directory("distributed_part_resume_reference_" + c);
  const test::CliResult r = test::run_mpi(2, "run " + scene + " --out " + reference.string() + options);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const auto& [first, then] : {std::pair{2, 2}, std::pair{2, 1}, std::pair{1, 2}}) {
    SCOPED_TRACE("stopped on " + std::to_string(first) + ", resumed on " + std::to_string(then));
    const fs::path dir =
        test::fresh_directory("distributed_part_resume_" + c + std::to_string(first) + std::to_string(then));
    const std::string run = "run " + scene + " --out " + dir.string() + options;
    const auto launch = [&](int ranks, const std::string& command) {
      return ranks == 1 ? test::run_cli(command) : test::run_mpi(ranks, command);
    };
    setenv("PERISTAT_FAULT_KILL_IN_WRITE", std::to_string(kill).c_str(), 1);
    const test::CliResult killed = launch(first, run);
    unsetenv("PERISTAT_FAULT_KILL_IN_WRITE");
    ASSERT_NE(killed.exit_code, 0) << "the run was not stopped";
    ASSERT_EQ(test::read_json(dir / "summary.json")["steps"].size(), static_cast<std::size_t>(kill - 1));
    const test::CliResult resumed = launch(then, run + " --resume");
    ASSERT_EQ(resumed.exit_code, 0) << resumed.out << resumed.err;
    const nlohmann::json summary = test::read_json(dir / "summary.json");
    EXPECT_EQ(summary["status"], "completed");
    EXPECT_EQ(summary["steps"].size(), static_cast<std::size_t>(steps));
    if (then == 2) {
      EXPECT_EQ(summary["run"]["model"], "part") << "the resumed run's own record";
    }
    const test::CliResult cmp = test::run_cli("compare " + (dir / (c + ".h5")).string() + " " +
                                              (reference / (c + ".h5")).string() + " --json");
    ASSERT_EQ(cmp.exit_code, 0) << cmp.err;
    EXPECT_LT(test::json_number(cmp.out, "relative_l2"), 1e-10);
  }
}

// A run on the parts writes the whole model's state into its checkpoint (gathered by global
// id: the state, and with contact every pair with its friction slip and the displacement of
// the last partner search), so it resumes on the parts, on one process, and a one-process
// checkpoint resumes on the parts. The tension plate (2 steps: on the parts under mpirun, whole
// in one process) is killed in step 2's write, case 4.3 (4 steps, friction, exact enforcement:
// the multipliers too) in step 3's. Each resumed run must end where the uninterrupted run on the parts ends: 1e-10, the
// resume tests' bound (measured 2.8e-12 to 4.1e-12 on the plate).
TEST(Distributed, ARunOnThePartsResumesOnAnyNumberOfRanks) {
  expect_resumes_on_parts("tension_plate",
                          " --quiet --set discretization.spacing=2e-3 --set solver.linear=belos", 2, 2);
  expect_resumes_on_parts("paper_4_3_precracked_plate",
                          " --quiet --set discretization.spacing=0.02 --set solver.linear=belos"
                          " --set contact.enforcement=exact",
                          4, 3);
}

// With failure: case 4.4 (dx = 0.05 m, 6 steps; bonds break from step 3) killed in step 5's
// write. The checkpoint holds every broken bond by the whole model's index and each particle's
// skew reference bond, gathered from the parts; a part resuming it breaks the pairs it holds
// and takes its families' references. Each resumed run ends where the uninterrupted run ends.
// Newton's tolerance is 1e-12 here: a resumed step starts without the secant predictor, so
// its Newton stops elsewhere inside the tolerance, and at the default 1e-10 the cracked plate
// ends up to 1.9e-10 apart; at 1e-12 what is left is the resume's own difference.
TEST(Distributed, ARunWithFailureOnThePartsResumesOnAnyNumberOfRanks) {
  expect_resumes_on_parts("paper_4_4_crack_growth",
                          " --quiet --set discretization.spacing=0.05 --set solver.linear=belos"
                          " --set solver.newton.rtol=1e-12",
                          6, 5);
}

TEST(Distributed, SlidingPlatesOnTwoRanksEqualSerial) {
  // Case 4.1: frictional contact, pairs that slip (GMRES while they do).
  const Pair p = run_both("paper_4_1_sliding_plates", "paper_4_1_sliding_plates", " --set discretization.spacing=1e-3");
  expect_same_answer(p);
}

TEST(Distributed, SlidingPlatesOnStripsEqualSerial) {
  // solver.belos.partition: strips (the default, rcb, is what the other tests run). Strips of
  // case 4.1 put one plate on each rank (the particles are numbered body by body), where RCB
  // cuts both plates across.
  const Pair p = run_both("paper_4_1_sliding_plates", "paper_4_1_sliding_plates",
                          " --set discretization.spacing=1e-3 --set solver.belos.partition=strips");
  expect_same_answer(p);
}

TEST(Distributed, PrecrackedPlateOnTwoRanksEqualsSerial) {
  // Case 4.3: a closed inclined crack with friction.
  const Pair p =
      run_both("paper_4_3_precracked_plate", "paper_4_3_precracked_plate", " --set discretization.spacing=0.02");
  expect_same_answer(p);
}

// solver.krylov.factors float on the ranks' parts: each rank keeps its families' factors in
// single precision, scaled family by family as one process does, and the answer is the
// serial float run's (and the double one's) to the Newton tolerance. Case 4.3: friction,
// pairs that slip (GMRES).
TEST(Distributed, FloatFactorsOnTwoRanksEqualSerial) {
  const Pair p = run_both("paper_4_3_precracked_plate", "paper_4_3_precracked_plate",
                          " --set discretization.spacing=0.02 --set solver.krylov.factors=float");
  expect_same_answer(p);
  for (const char* which : {"serial", "mpi"})
    EXPECT_EQ(test::read_json(p.dir / which / "summary.json")["run"]["solver"]["action_factors"], "float")
        << which;
}

// Case 4.4 at dx = 0.05 m: bonds break in the later steps; the two runs must break the
// same ones (equal damage at every particle, to the last bit: damage is a count of broken
// bonds over the family's), step by step.
void expect_same_damage(const fs::path& reference, const fs::path& other) {
  const ResultsReader a(reference.string()), b(other.string());
  ASSERT_EQ(a.steps(), b.steps());
  double broken_somewhere = 0.0;
  for (const int step : a.steps()) {
    const VectorXd da = a.damage(step), db = b.damage(step);
    ASSERT_EQ(da.size(), db.size());
    EXPECT_EQ((da - db).cwiseAbs().maxCoeff(), 0.0) << "damage, step " << step;
    broken_somewhere = std::max(broken_somewhere, da.maxCoeff());
  }
  EXPECT_GT(broken_somewhere, 0.0) << "the scene must break bonds for this test to mean anything";
}

void expect_same_bonds_broken(const Pair& p) {
  expect_same_answer(p);  // bonds partitioned, failure decided over the ranks
  expect_same_damage(p.h5("serial"), p.h5("mpi"));
}

// Failure on the ranks' parts (docs/guide/distributed.md, "Failure on the parts"): case 4.4
// at dx = 0.05 m, with its crack's frictional contact and without contact. Each part proposes its own
// families' pairs by global id, every rank breaks the same pairs, the pieces of the bond graph are joined
// across the parts: the serial answer within 1e-8, the same damage at every particle to the bit, and per step
// the same counts of broken bonds, fragments and contact pairs and the same closest intact
// bond (its ratio to round-off, the iterative solve's answer differing from CHOLMOD's by
// about 1e-11 here; its place exactly while it carries load).
// `fragments`: whether the crack cuts a piece loose by the last step. Each step's `held`
// dataset (gathered from the parts on two ranks) names as many particles as the step's count
// fragment_particles, and compare leaves exactly those out.
void expect_failure_on_parts_as_serial(const std::string& extra, bool fragments) {
  SCOPED_TRACE(extra);
  const Pair p = run_both("paper_4_4_crack_growth", "paper_4_4_crack_growth",
                          " --set discretization.spacing=0.05" + extra);
  expect_same_bonds_broken(p);
  const nlohmann::json mpi = test::read_json(p.dir / "mpi" / "summary.json"),
                       serial = test::read_json(p.dir / "serial" / "summary.json");
  EXPECT_EQ(mpi["run"]["model"], "part");
  ASSERT_EQ(mpi["steps"].size(), serial["steps"].size());
  for (std::size_t k = 0; k < serial["steps"].size(); ++k) {
    const nlohmann::json &a = mpi["steps"][k]["counts"], &b = serial["steps"][k]["counts"];
    for (const char* key : {"broken_bonds_total", "bonds_broken", "fragments", "fragment_particles"})
      EXPECT_EQ(a[key], b[key]) << key << ", step " << k + 1;
    EXPECT_NEAR(a["criterion_peak"].get<double>(), b["criterion_peak"].get<double>(), 1e-8)
        << "step " << k + 1;
    // Where the peak is means something while a bond carries load: without contact the
    // crack cuts the plate through in step 5, and every ratio after is round-off (1e-13).
    if (b["criterion_peak"].get<double>() > 1e-3) {
      for (const char* key : {"criterion_peak_x", "criterion_peak_y"})
        EXPECT_EQ(a[key], b[key]) << key << ", step " << k + 1;
    }
    if (b.contains("contact_candidates")) {
      for (const char* key : {"contact_candidates", "contact_stick", "contact_slip"})
        EXPECT_EQ(a[key], b[key]) << key << ", step " << k + 1;
    }
  }
  EXPECT_GT(serial["steps"].back()["counts"]["broken_bonds_total"].get<double>(), 100.0)
      << "the crack must grow for this test to mean anything";
  for (const char* which : {"serial", "mpi"}) {
    const ResultsReader r(p.h5(which).string());
    const nlohmann::json& summary = std::string(which) == "serial" ? serial : mpi;
    for (const int step : r.steps())
      EXPECT_EQ(r.held(step).sum(), summary["steps"][step - 1]["counts"]["fragment_particles"].get<double>())
          << which << ", step " << step;
  }
  const double held = serial["steps"].back()["counts"]["fragment_particles"].get<double>();
  EXPECT_EQ(held > 0.0, fragments) << "the held particles are part of what this run checks";
  const test::CliResult c =
      test::run_cli("compare " + p.h5("mpi").string() + " " + p.h5("serial").string() + " --json");
  EXPECT_EQ(test::json_number(c.out, "held_left_out"), held);
}

TEST(Distributed, CrackGrowthOnThePartsBreaksTheSameBonds) {
  expect_failure_on_parts_as_serial("", false);
  expect_failure_on_parts_as_serial(" --set contact.enabled=false", true);
}

// The tests above run the defaults, a matrix-free tangent (Belos applies the problem's action,
// each rank its rows from the whole vector) preconditioned by MueLu on the bond matrix. The
// assembled tangent with the factor of each rank's block of the bond matrix (the defaults
// before 2026-11-26) stays an option: the same bounds, since the answers stop at the same
// Newton and Krylov tolerances.
const char* const kAssembled =
    " --set solver.belos.tangent=assembled --set solver.belos.preconditioner=bond_factor";

TEST(Distributed, AssembledTangentOnTwoRanksEqualsSerial) {
  const Pair p = run_both("tension_plate", "tension_plate",
                          std::string(" --set discretization.spacing=2e-3") + kAssembled);
  expect_same_answer(p);
  // Each rank assembles only its rows of the tangent; summary.json counts them over the
  // ranks, which must give the one-process tangent's count exactly (the ranks own every
  // row once; unit.ModelPart.PartMatricesAreTheWholeRows* check the entries themselves).
  const std::string scene = std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml";
  const test::CliResult one =
      test::run_cli("run " + scene + " --quiet --out " + (p.dir / "one").string() +
                    " --set discretization.spacing=2e-3 --set solver.linear=belos" + kAssembled);
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const long long whole = test::read_json(p.dir / "one" / "summary.json")["run"]["tangent_nonzeros"];
  const long long ranks = test::read_json(p.dir / "mpi" / "summary.json")["run"]["tangent_nonzeros"];
  EXPECT_GT(whole, 0);
  EXPECT_EQ(ranks, whole);
  expect_same_answer(run_both("paper_4_1_sliding_plates", "paper_4_1_sliding_plates",
                              std::string(" --set discretization.spacing=1e-3") + kAssembled));
  expect_same_answer(run_both("paper_4_3_precracked_plate", "paper_4_3_precracked_plate",
                              std::string(" --set discretization.spacing=0.02") + kAssembled));
}

TEST(Distributed, AssembledTangentOnTwoRanksBreaksTheSameBonds) {
  expect_same_bonds_broken(run_both("paper_4_4_crack_growth", "paper_4_4_crack_growth",
                                    std::string(" --set discretization.spacing=0.05") + kAssembled));
}

// A checkpoint names broken bonds by their index in the whole model (Model::whole_start), so a
// run stopped on one process resumes on two ranks' parts, and the other way round
// (docs/guide/distributed.md, "Failure on the parts"). Case 4.4 at dx 0.05 m is killed
// inside the write of step 5's results (PERISTAT_FAULT_KILL_IN_WRITE, as regression.Resume.*
// does): its checkpoint holds step 4, after the first 24 bonds broke. The resumed run breaks
// the rest in steps 5 and 6 and must end where the uninterrupted serial run ends: 1e-10, the
// resume tests' bound, and the same damage at every particle of every step. Newton's
// tolerance is 1e-12: the runs change solver at the resume (Belos on the ranks, CG in one
// process), and at the default 1e-10 two solvers stop 1.4e-10 apart on step 6 (measured
// stopped on two ranks, resumed on one); at 1e-12, 1.6e-15.
TEST(Distributed, ACheckpointResumesOnAnotherNumberOfRanks) {
  const std::string scene = std::string(PERISTAT_SOURCE_DIR) + "/cases/paper_4_4_crack_growth/scene.yaml";
  const std::string options =
      " --quiet --threads 1 --set discretization.spacing=0.05 --set solver.newton.rtol=1e-12";
  const fs::path reference = test::fresh_directory("distributed_resume_reference");
  const test::CliResult r = test::run_cli("run " + scene + " --out " + reference.string() + options);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string h5 = "paper_4_4_crack_growth.h5";
  for (const int first_ranks : {1, 2}) {
    SCOPED_TRACE(first_ranks == 1 ? "stopped on one process, resumed on two ranks"
                                  : "stopped on two ranks, resumed on one process");
    const fs::path dir = test::fresh_directory("distributed_resume_" + std::to_string(first_ranks));
    const std::string run = "run " + scene + " --out " + dir.string() + options;
    setenv("PERISTAT_FAULT_KILL_IN_WRITE", "5", 1);
    const test::CliResult killed = first_ranks == 1 ? test::run_cli(run) : test::run_mpi(2, run);
    unsetenv("PERISTAT_FAULT_KILL_IN_WRITE");
    ASSERT_NE(killed.exit_code, 0) << "the run was not stopped";
    ASSERT_EQ(test::read_json(dir / "summary.json")["steps"].size(), 4u);
    const test::CliResult resumed = first_ranks == 1 ? test::run_mpi(2, run + " --resume") : test::run_cli(run + " --resume");
    ASSERT_EQ(resumed.exit_code, 0) << resumed.out << resumed.err;
    const nlohmann::json summary = test::read_json(dir / "summary.json");
    EXPECT_EQ(summary["status"], "completed");
    EXPECT_EQ(summary["steps"].size(), 6u);
    EXPECT_EQ(summary["run"].value("bonds_held", "none"), first_ranks == 1 ? "partitioned" : "none")
        << "the resumed run's own record";
    const test::CliResult cmp =
        test::run_cli("compare " + (dir / h5).string() + " " + (reference / h5).string() + " --json");
    ASSERT_EQ(cmp.exit_code, 0) << cmp.err;
    EXPECT_LT(test::json_number(cmp.out, "relative_l2"), 1e-10);
    const ResultsReader a((dir / h5).string()), b((reference / h5).string());
    ASSERT_EQ(a.steps(), b.steps());
    for (const int step : a.steps())
      EXPECT_TRUE((a.damage(step).array() == b.damage(step).array()).all()) << "damage, step " << step;
    EXPECT_GT(a.damage(6).maxCoeff(), 0.0);
  }
}

// Distributed ADR (docs/guide/distributed.md): each rank relaxes its own unknowns, from the
// residual of its rows (unit.ModelPart.PartRowsAreTheWholeRows* prove those rows bit for bit), and shares
// them every pseudo-time step. Only the sums of the residual norm and of the damping's
// Rayleigh quotient change order, and ADR's iteration count is sensitive to that round-off:
// the serial run with its quotient summed backwards took 284 + 69 iterations on the tension
// plate instead of 288 + 49 and moved by 1.7e-8. So the two-rank run is held to ADR's own
// accuracy, not to the serial ADR's bits: its distance from the Newton answer (CHOLMOD,
// Newton rtol 1e-10) within twice the serial ADR's (measured: 1.47e-8 against 1.69e-8 on the
// tension plate, 1.653e-8 against 1.656e-8 on case 4.3). A rank that evaluated a wrong
// residual would not converge, or would land far outside that.
void expect_adr_as_accurate_as_serial(const std::string& c, const std::string& extra,
                                      const std::string& model = "") {
  const fs::path dir = test::fresh_directory("distributed_adr_" + c);
  const std::string scene = std::string(PERISTAT_SOURCE_DIR) + "/cases/" + c + "/scene.yaml";
  const std::string run = "run " + scene + " --quiet" + extra + " --out ";
  const test::CliResult newton =
      test::run_cli(run + (dir / "newton").string() + " --set solver.linear=cholmod");
  const test::CliResult serial = test::run_cli(run + (dir / "serial").string() + " --solver adr");
  const test::CliResult ranks = test::run_mpi(2, run + (dir / "mpi").string() + " --solver adr");
  ASSERT_EQ(newton.exit_code, 0) << newton.err;
  ASSERT_EQ(serial.exit_code, 0) << serial.err;
  ASSERT_EQ(ranks.exit_code, 0) << ranks.out << ranks.err;
  const auto error = [&](const char* which) {
    const test::CliResult cmp = test::run_cli("compare " + (dir / which / (c + ".h5")).string() + " " +
                                              (dir / "newton" / (c + ".h5")).string() + " --json");
    EXPECT_EQ(cmp.exit_code, 0) << cmp.err;
    return test::json_number(cmp.out, "relative_l2");
  };
  const double e_serial = error("serial"), e_ranks = error("mpi");
  EXPECT_GT(e_serial, 0.0) << "ADR stops at its tolerance, not at Newton's answer";
  EXPECT_LE(e_ranks, 2.0 * e_serial) << "two-rank ADR " << e_ranks << ", serial ADR " << e_serial;
  const nlohmann::json summary = test::read_json(dir / "mpi" / "summary.json");
  EXPECT_EQ(summary["status"], "completed");
  EXPECT_EQ(summary["run"]["bonds_held"], "partitioned") << "a part holds some families only";
  EXPECT_EQ(listing(dir / "mpi"), listing(dir / "serial")) << "the files of a serial run, no more";
  if (!model.empty()) {
    EXPECT_EQ(summary["run"]["model"], model);
  }
}

TEST(Distributed, AdrOnTwoRanksIsAsAccurateAsSerialAdr) {
  // Under mpirun `auto` runs ADR on the ranks' parts for a scene without contact.
  expect_adr_as_accurate_as_serial("tension_plate", " --set discretization.spacing=2e-3", "part");
}

// ADR on the ranks' parts (docs/guide/distributed.md, "Distributed ADR"): each part holds two
// rings of families (the assembled tangent's rows give ADR's density), updates its own
// unknowns and imports its ghosts' from their owners. Case 4.3 (the crack's frictional pairs)
// as accurate as serial ADR. Case 4.4 (bonds
// breaking) against Newton only, to keep CI short (serial ADR takes a minute here): the same
// damage at every particle and step, and the answer within 1e-7 of Newton's (ADR stops at
// rtol 1e-8 of the force scale; serial ADR is 3.0e-8 from Newton here, two ranks 3.0e-8).
TEST(Distributed, AdrOnThePartsIsAsAccurateAsSerialAdr) {
  expect_adr_as_accurate_as_serial("paper_4_3_precracked_plate",
                                   " --set discretization.spacing=0.02", "part");
  const std::string c = "paper_4_4_crack_growth";
  const fs::path dir = test::fresh_directory("distributed_adr_part_" + c);
  const std::string run = "run " + std::string(PERISTAT_SOURCE_DIR) + "/cases/" + c +
                          "/scene.yaml --quiet --set discretization.spacing=0.05 --out ";
  const test::CliResult newton =
      test::run_cli(run + (dir / "newton").string() + " --set solver.linear=cholmod");
  const test::CliResult ranks =
      test::run_mpi(2, run + (dir / "mpi").string() + " --solver adr");
  ASSERT_EQ(newton.exit_code, 0) << newton.err;
  ASSERT_EQ(ranks.exit_code, 0) << ranks.out << ranks.err;
  EXPECT_EQ(test::read_json(dir / "mpi" / "summary.json")["run"]["model"], "part");
  expect_same_damage(dir / "newton" / (c + ".h5"), dir / "mpi" / (c + ".h5"));
  const test::CliResult cmp = test::run_cli("compare " + (dir / "mpi" / (c + ".h5")).string() + " " +
                                            (dir / "newton" / (c + ".h5")).string() + " --json");
  ASSERT_EQ(cmp.exit_code, 0) << cmp.err;
  EXPECT_LT(test::json_number(cmp.out, "relative_l2"), 1e-7);
}

TEST(Distributed, OtherSolversAreRefusedUnderMpirun) {
  // Newton with a serial linear solver: the ranks would each run the whole serial solve;
  // refused (exit 2) with the ways out.
  const std::string scene = std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml";
  const fs::path dir = test::fresh_directory("distributed_refused");
  const test::CliResult r = test::run_mpi(2, "run " + scene + " --quiet --out " + dir.string() +
                                                 " --set discretization.spacing=5e-3 --set solver.linear=cholmod");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("solver.linear=belos"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "tension_plate.h5")) << "nothing is written";
  // ADR breaking bonds during its iterations reads every family's state at every step, which a
  // rank relaxing its own unknowns does not have: refused (exit 2), nothing written.
  const fs::path adr = test::fresh_directory("distributed_refused_breaking");
  const std::string c44 = std::string(PERISTAT_SOURCE_DIR) + "/cases/paper_4_4_crack_growth/scene.yaml";
  const test::CliResult b = test::run_mpi(2, "run " + c44 + " --quiet --out " + adr.string() +
                                                 " --solver adr --set discretization.spacing=0.1"
                                                 " --set solver.adr.breaking=iterations");
  EXPECT_EQ(b.exit_code, 2) << b.err;
  EXPECT_NE(b.err.find("solver.adr.breaking"), std::string::npos) << b.err;
  EXPECT_FALSE(fs::exists(adr / "paper_4_4_crack_growth.h5")) << "nothing is written";
}

TEST(Distributed, AMueLuListThatIsNotXmlIsRefused) {
  // solver.belos.muelu_parameters: a readable file that Teuchos cannot parse ends the run
  // with exit 2 and the key before anything is written.
  const fs::path dir = test::fresh_directory("distributed_muelu_xml");
  const fs::path xml = dir / "muelu.xml";
  std::ofstream(xml) << "this is not XML\n";
  const std::string scene = std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml";
  const test::CliResult r = test::run_cli("run " + scene + " --quiet --out " + (dir / "out").string() +
                                          " --set discretization.spacing=5e-3 --set solver.linear=belos"
                                          " --set solver.belos.preconditioner=muelu --set solver.belos.muelu_parameters=" +
                                          xml.string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("solver.belos.muelu_parameters"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out" / "tension_plate.h5"));
}

}  // namespace
}  // namespace peristat
