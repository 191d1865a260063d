// Difference measures of `peristat compare` (io/compare.hpp): on in-memory tables and on
// small results files written with ResultsWriter.
#include <cmath>
#include <filesystem>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "io/compare.hpp"
#include "io/results.hpp"

namespace peristat {
namespace {

namespace fs = std::filesystem;

// Rounding only: the measures are a few dozen sums and one square root.
constexpr double k_tight = 1e-12;

/// Two bodies of 4 x 2 particles, spacing 0.5: "left" (body 0) for x < 2 and "right"
/// (body 1) beside it; the first particle of each body is fictitious.
ParticleTable two_bodies() {
  ParticleTable t;
  t.spacing = 0.5;
  t.body_names = {"left", "right"};
  for (int body = 0; body < 2; ++body) {
    for (int j = 0; j < 2; ++j) {
      for (int i = 0; i < 4; ++i) {
        t.position.emplace_back(0.25 + 0.5 * i + 2.0 * body, 0.25 + 0.5 * j);
        t.volume.push_back(0.25);
        t.body.push_back(body);
        t.fictitious.push_back(i == 0 && j == 0 ? 1 : 0);
      }
    }
  }
  return t;
}

/// A displacement that varies per particle and component (no particle at rest).
VectorXd reference_field(const ParticleTable& t) {
  VectorXd u(2 * static_cast<Eigen::Index>(t.size()));
  for (std::size_t i = 0; i < t.size(); ++i) {
    const auto k = 2 * static_cast<Eigen::Index>(i);
    u[k] = 1e-4 * t.position[i].x();
    u[k + 1] = -3e-5 * t.position[i].y() + 1e-6 * static_cast<double>(i);
  }
  return u;
}

/// Sets the displacement of the fictitious particles to something far off.
void spoil_fictitious(const ParticleTable& t, VectorXd& u) {
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t.fictitious[i] != 0) u.segment<2>(2 * static_cast<Eigen::Index>(i)) = Vec2(1.0, -2.0);
  }
}

TEST(CompareDisplacements, IdenticalFieldsGiveZero) {
  const ParticleTable t = two_bodies();
  const VectorXd u = reference_field(t);
  const Comparison c = compare_displacements(t, u, u);
  EXPECT_EQ(c.all.particles, 14);  // 16 particles, 2 fictitious
  EXPECT_EQ(c.all.relative_l2, 0.0);
  EXPECT_EQ(c.all.max_abs, 0.0);
  EXPECT_EQ(c.all.max_relative, 0.0);
  EXPECT_FALSE(c.all.absolute);
  ASSERT_EQ(c.bodies.size(), 2u);
  for (const BodyDifference& b : c.bodies) {
    EXPECT_EQ(b.measures.particles, 7);
    EXPECT_EQ(b.measures.relative_l2, 0.0);
    EXPECT_EQ(b.measures.max_abs, 0.0);
  }
}

// uA = 1.01 uB: du = 0.01 uB everywhere, so both ratios are 0.01 overall and per body;
// the fictitious particles (spoiled in A) do not count.
TEST(CompareDisplacements, ScaledFieldGivesTheScaleMinusOne) {
  const ParticleTable t = two_bodies();
  const VectorXd u_b = reference_field(t);
  VectorXd u_a = 1.01 * u_b;
  spoil_fictitious(t, u_a);
  const Comparison c = compare_displacements(t, u_a, u_b);
  EXPECT_NEAR(c.all.relative_l2, 0.01, k_tight);
  EXPECT_NEAR(c.all.max_relative, 0.01, k_tight);
  double max_b = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t.fictitious[i] == 0)
      max_b = std::max(max_b, u_b.segment<2>(2 * static_cast<Eigen::Index>(i)).norm());
  }
  EXPECT_NEAR(c.all.max_abs, 0.01 * max_b, k_tight * max_b);
  EXPECT_NEAR(c.all.max_b, max_b, k_tight * max_b);
  ASSERT_EQ(c.bodies.size(), 2u);
  EXPECT_EQ(c.bodies[0].name, "left");
  EXPECT_EQ(c.bodies[1].name, "right");
  for (const BodyDifference& b : c.bodies) {
    EXPECT_NEAR(b.measures.relative_l2, 0.01, k_tight) << b.name;
    EXPECT_NEAR(b.measures.max_relative, 0.01, k_tight) << b.name;
  }
}

// A differs from B by a constant d = (3e-6, -4e-6) (|d| = 5e-6) on body "right" only.
TEST(CompareDisplacements, PerBodyValues) {
  const ParticleTable t = two_bodies();
  const VectorXd u_b = reference_field(t);
  VectorXd u_a = u_b;
  double sum_b2_right = 0.0, sum_b2 = 0.0, max_b_right = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t.fictitious[i] != 0) continue;
    const auto k = 2 * static_cast<Eigen::Index>(i);
    const double b2 = u_b.segment<2>(k).squaredNorm();
    sum_b2 += b2;
    if (t.body[i] == 1) {
      u_a.segment<2>(k) += Vec2(3e-6, -4e-6);
      sum_b2_right += b2;
      max_b_right = std::max(max_b_right, std::sqrt(b2));
    }
  }
  const Comparison c = compare_displacements(t, u_a, u_b);
  const double norm_diff = 5e-6 * std::sqrt(7.0);  // 7 real particles on the right
  EXPECT_NEAR(c.all.relative_l2, norm_diff / std::sqrt(sum_b2), k_tight);
  EXPECT_NEAR(c.all.max_abs, 5e-6, k_tight * 5e-6);
  ASSERT_EQ(c.bodies.size(), 2u);
  EXPECT_EQ(c.bodies[0].measures.relative_l2, 0.0);
  EXPECT_EQ(c.bodies[0].measures.max_abs, 0.0);
  EXPECT_NEAR(c.bodies[1].measures.relative_l2, norm_diff / std::sqrt(sum_b2_right), k_tight);
  EXPECT_NEAR(c.bodies[1].measures.max_abs, 5e-6, k_tight * 5e-6);
  EXPECT_NEAR(c.bodies[1].measures.max_relative, 5e-6 / max_b_right, k_tight);
}

TEST(CompareDisplacements, ZeroReferenceFallsBackToAbsoluteValues) {
  const ParticleTable t = two_bodies();
  const VectorXd u_b = VectorXd::Zero(2 * static_cast<Eigen::Index>(t.size()));
  VectorXd u_a = u_b;
  u_a[2] = 3e-6;  // particle 1 (real, body 0)
  u_a[3] = 4e-6;
  const Comparison c = compare_displacements(t, u_a, u_b);
  EXPECT_TRUE(c.all.absolute);
  EXPECT_NEAR(c.all.relative_l2, 5e-6, k_tight * 5e-6);
  EXPECT_NEAR(c.all.max_relative, 5e-6, k_tight * 5e-6);
  EXPECT_TRUE(c.bodies[1].measures.absolute);
  EXPECT_EQ(c.bodies[1].measures.relative_l2, 0.0);
}

TEST(CompareDisplacements, BodiesWithoutNamesAreLabelledByIndex) {
  ParticleTable t = two_bodies();
  t.body_names.clear();
  const VectorXd u = reference_field(t);
  const Comparison c = compare_displacements(t, u, u);
  ASSERT_EQ(c.bodies.size(), 2u);
  EXPECT_EQ(c.bodies[0].name, "0");
  EXPECT_EQ(c.bodies[1].name, "1");
}

TEST(CompareDisplacements, WrongSizeIsAnInputError) {
  const ParticleTable t = two_bodies();
  const VectorXd u = reference_field(t);
  EXPECT_THROW(compare_displacements(t, u, u.head(4)), InputError);
}

TEST(ParticleMismatch, SameTablesMatch) {
  EXPECT_EQ(particle_mismatch(two_bodies(), "a.h5", two_bodies(), "b.h5"), "");
}

TEST(ParticleMismatch, NamesWhatDiffers) {
  const ParticleTable b = two_bodies();

  ParticleTable a = two_bodies();
  a.position.pop_back();
  a.volume.pop_back();
  a.body.pop_back();
  a.fictitious.pop_back();
  EXPECT_EQ(particle_mismatch(a, "a.h5", b, "b.h5"), "a.h5 has 15 particles, b.h5 has 16");

  a = two_bodies();
  a.fictitious[3] = 1;
  const std::string fictitious = particle_mismatch(a, "a.h5", b, "b.h5");
  EXPECT_NE(fictitious.find("particle 3 is fictitious in a.h5 but not in b.h5"), std::string::npos)
      << fictitious;

  a = two_bodies();
  a.body[5] = 1;
  const std::string body = particle_mismatch(a, "a.h5", b, "b.h5");
  EXPECT_NE(body.find("particle 5 belongs to body 1 in a.h5 and to body 0 in b.h5"), std::string::npos)
      << body;

  // Largest |position| is about 3.8 m: tolerance 3.8e-9 m.
  a = two_bodies();
  a.position[7].x() += 1e-7;
  const std::string position = particle_mismatch(a, "a.h5", b, "b.h5");
  EXPECT_NE(position.find("particle 7 is at"), std::string::npos) << position;
  EXPECT_NE(position.find("1 of 16 particles differ"), std::string::npos) << position;

  a = two_bodies();
  a.position[7].x() += 1e-10;  // within the tolerance
  EXPECT_EQ(particle_mismatch(a, "a.h5", b, "b.h5"), "");
}

// ---- through files ---------------------------------------------------------------------

class CompareFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    m_dir = fs::temp_directory_path() /
            ("peristat_test_compare_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(m_dir);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(m_dir, ignored);
  }

  /// Writes DIR/<name>/<name>.h5 with one step per field (step k has fields[k-1],
  /// load factor k / n, and held[k-1] when given and not empty) and returns its path.
  std::string write(const std::string& name, const ParticleTable& table, const std::vector<VectorXd>& fields,
                    const std::vector<std::vector<int>>& held = {}) {
    const std::string dir = (m_dir / name).string();
    ResultsWriter writer(dir, name, "name: " + name + "\n", table, "{}");
    for (std::size_t k = 0; k < fields.size(); ++k) {
      StepRecord r;
      r.index = static_cast<int>(k + 1);
      r.load_factor = static_cast<double>(k + 1) / static_cast<double>(fields.size());
      r.displacement = &fields[k];
      if (k < held.size() && !held[k].empty()) r.held = &held[k];
      writer.write_step(r);
    }
    writer.finish("completed", "");
    return writer.h5_path();
  }

 private:
  fs::path m_dir;
};

TEST_F(CompareFiles, ReadsBothFilesAndComparesTheChosenSteps) {
  const ParticleTable t = two_bodies();
  const VectorXd u = reference_field(t);
  VectorXd u_scaled = 1.01 * u;
  spoil_fictitious(t, u_scaled);
  const std::string a = write("a", t, {0.5 * u, u_scaled});
  const std::string b = write("b", t, {0.5 * u, u});
  const ResultsReader ra(a), rb(b);

  const Comparison last = compare_results(ra, a, 2, rb, b, 2);
  EXPECT_NEAR(last.all.relative_l2, 0.01, k_tight);
  EXPECT_NEAR(last.all.max_relative, 0.01, k_tight);
  ASSERT_EQ(last.bodies.size(), 2u);
  EXPECT_EQ(last.bodies[0].name, "left");
  EXPECT_NEAR(last.bodies[1].measures.relative_l2, 0.01, k_tight);

  EXPECT_EQ(compare_results(ra, a, 1, rb, b, 1).all.relative_l2, 0.0);
  // Step 1 of A against step 2 of B: uA = uB / 2.
  EXPECT_NEAR(compare_results(ra, a, 1, rb, b, 2).all.relative_l2, 0.5, k_tight);
}

// A particle either file holds as a fragment is left out and counted: its position is not
// determined by the equations. Particles 3 (body 0) and 9 (body 1) are 1 m off in A's last
// step; B holds 3 there and A holds 9, so the rest compares exactly equal. Step 1 holds no
// dataset (a run without failure): nothing is left out and the 1 m shows.
TEST_F(CompareFiles, ParticlesHeldAsFragmentsInEitherFileAreLeftOut) {
  const ParticleTable t = two_bodies();
  const VectorXd u = reference_field(t);
  VectorXd off = u;
  for (const Eigen::Index i : {3, 9}) off.segment<2>(2 * i) += Vec2(1.0, 0.0);
  std::vector<int> held_a(t.size(), 0), held_b(t.size(), 0);
  held_a[9] = 1;
  held_b[3] = 1;
  const std::string a = write("a", t, {off, off}, {{}, held_a});
  const std::string b = write("b", t, {u, u}, {{}, held_b});
  const ResultsReader ra(a), rb(b);
  EXPECT_EQ(ra.held(1), VectorXd::Zero(16));
  EXPECT_EQ(ra.held(2)[9], 1.0);
  EXPECT_EQ(ra.held(2).sum(), 1.0);

  const Comparison last = compare_results(ra, a, 2, rb, b, 2);
  EXPECT_EQ(last.held_left_out, 2);
  EXPECT_EQ(last.all.particles, 12);  // 14 real particles, 2 held
  EXPECT_EQ(last.all.relative_l2, 0.0);
  EXPECT_EQ(last.all.max_abs, 0.0);
  ASSERT_EQ(last.bodies.size(), 2u);
  EXPECT_EQ(last.bodies[0].measures.particles, 6);
  EXPECT_EQ(last.bodies[1].measures.particles, 6);

  const Comparison first = compare_results(ra, a, 1, rb, b, 1);
  EXPECT_EQ(first.held_left_out, 0);
  EXPECT_EQ(first.all.particles, 14);
  EXPECT_NEAR(first.all.max_abs, 1.0, 1e-12);

  // Every real particle held: nothing is left to compare, and a verdict over nothing would
  // pass any tolerance, so it is refused.
  std::vector<int> all_held(t.size(), 1);
  const std::string c = write("c", t, {u}, {all_held});
  const ResultsReader rc(c);
  EXPECT_THROW(compare_results(rc, c, 1, rb, b, 1), InputError);
}

TEST_F(CompareFiles, DifferentParticlesAndMissingStepsNameTheFiles) {
  const ParticleTable t = two_bodies();
  ParticleTable moved = two_bodies();
  moved.position[2].y() += 0.01;
  const std::string a = write("a", t, {reference_field(t)});
  const std::string b = write("b", moved, {reference_field(moved)});
  const ResultsReader ra(a), rb(b);
  try {
    compare_results(ra, a, 1, rb, b, 1);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(a + " and " + b + " do not hold the same particles"), std::string::npos) << what;
    EXPECT_NE(what.find("particle 2 is at"), std::string::npos) << what;
  }
  try {
    compare_results(ra, a, 1, ra, a, 3);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("step 3 is not in '" + a + "'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace peristat
