// Bond failure with partitioned bonds (issue 16; docs/guide/distributed.md, "Partitioned
// bonds"): each rank holds some families only and proposes the pairs of its own families;
// the candidates over the criterion, the damage and the pieces of the bond graph are
// gathered over the ranks. Ranks emulated by threads (test::EmulatedRanks) must take one
// process's decisions bit for bit: the same pairs broken in the same order round by round,
// the same peak, damage, fragments and checkpoint, and the checkpoint restored on the ranks
// must give the same state again.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "app/setup.hpp"
#include "assembly/pattern.hpp"
#include "assembly/quasi_static.hpp"
#include "materials/failure.hpp"
#include "materials/osb.hpp"
#include "support/emulated_ranks.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

struct Record {
  std::vector<std::vector<std::pair<Index, Index>>> rounds;
  std::vector<BondFailure::Peak> peaks;
  Index broken = 0, fragment_particles = 0, fragments = 0;
  VectorXd damage;
  StateArchive saved;
  Index restored_broken = 0, restored_fragment_particles = 0;
  VectorXd restored_damage;
};

/// Breaks the bonds over the criterion at x in rounds of at most `at_most` pairs, committing
/// each, until a round breaks none; then saves the state and restores it into a fresh problem.
Record break_save_restore(const Model& model, const ProblemOptions& options, const VectorXd& x,
                          Index at_most) {
  Record rec;
  QuasiStaticProblem problem(model, options);
  problem.set_load_factor(0.0);
  for (int round = 0; round < 200; ++round) {
    const Index broke = problem.advance_irreversible_state(x, at_most);
    rec.rounds.push_back(problem.failure()->last_round());
    rec.peaks.push_back(problem.failure()->peak());
    if (broke == 0) break;
    problem.commit(x);
  }
  rec.broken = problem.failure()->broken();
  rec.damage = problem.damage();
  rec.fragment_particles = problem.fragment_particles();
  rec.fragments = problem.fragments();
  rec.saved.arrays.clear();
  problem.save_state(rec.saved);
  QuasiStaticProblem fresh(model, options);
  fresh.restore_state(rec.saved, x);
  rec.restored_broken = fresh.failure()->broken();
  rec.restored_damage = fresh.damage();
  rec.restored_fragment_particles = fresh.fragment_particles();
  return rec;
}

/// The options of one emulated rank: its rows, and every collective through `net`.
ProblemOptions rank_options(ProblemOptions options, test::EmulatedRanks& net, int rank,
                            const std::vector<int>& owner) {
  options.rows = OwnedRows{rank, owner};
  std::vector<int> component_owner(2 * owner.size());
  for (std::size_t p = 0; p < owner.size(); ++p)
    component_owner[2 * p] = component_owner[2 * p + 1] = owner[p];
  options.max_over_ranks = [&net, rank](double v) { return net.max(rank, v); };
  options.sum_over_ranks = [&net, rank](double v) { return net.sum(rank, v); };
  options.share_forces = [&net, rank, component_owner](VectorXd& f) {
    net.share(rank, component_owner, f.data(), static_cast<std::size_t>(f.size()));
  };
  options.gather_over_ranks = [&net, rank](const std::vector<double>& mine) {
    return net.gather(rank, mine);
  };
  options.share_particle_values = [&net, rank, owner](VectorXd& v) {
    net.share(rank, owner, v.data(), static_cast<std::size_t>(v.size()));
  };
  return options;
}

/// x: the affine field u = (shear y, stretch y) on every unknown, and particle `moved`
/// displaced by 10 dx along x, so that all its bonds break and it becomes a fragment.
VectorXd affine_state(const Model& model, double stretch, double shear, Index moved) {
  VectorXd x = VectorXd::Zero(model.constraints.n_free);
  for (Index p = 0; p < model.particles.size(); ++p) {
    const double y = model.particles.position[p].y();
    const Index fx = model.constraints.free_index[2 * p], fy = model.constraints.free_index[2 * p + 1];
    if (fx >= 0) x[fx] = shear * y + (p == moved ? 10 * model.spacing : 0.0);
    if (fy >= 0) x[fy] = stretch * y;
  }
  return x;
}

Index nearest_particle(const Model& model, const Vec2& at) {
  Index best = -1;
  for (Index p = 0; p < model.particles.size(); ++p)
    if (!model.particles.fictitious[p] && (best < 0 || (model.particles.position[p] - at).norm() <
                                                           (model.particles.position[best] - at).norm()))
      best = p;
  return best;
}

void expect_ranks_break_as_one_process(const Scene& scene, double stretch, double shear, Index at_most) {
  const Model model = discretise(scene);
  const Index moved = nearest_particle(model, Vec2(0.0255, 0.0125));
  const VectorXd x = affine_state(model, stretch, shear, moved);
  const Record whole = break_save_restore(model, problem_options(scene), x, at_most);
  // What makes the comparison mean something: several rounds, a fragment, and damage.
  ASSERT_GE(whole.rounds.size(), 4u);
  ASSERT_GT(whole.broken, 2 * at_most);
  ASSERT_EQ(whole.fragment_particles, 1) << "the moved particle is cut loose";
  EXPECT_EQ(whole.restored_broken, whole.broken);
  EXPECT_TRUE((whole.restored_damage.array() == whole.damage.array()).all());
  for (const int rings : {1, 2})
    for (const auto& [cuts, ranks] :
         {std::pair{false, 2}, std::pair{false, 3}, std::pair{true, 2}, std::pair{true, 3}}) {
      SCOPED_TRACE(std::string(cuts ? "cuts across x" : "strips") + " on " + std::to_string(ranks) +
                   " ranks, " + std::to_string(rings) + " ring(s)");
      const std::vector<int> owner =
          cuts ? test::x_cut_owners(model, ranks) : strip_owners(model.constraints, ranks);
      test::EmulatedRanks net(ranks);
      std::vector<Record> records(static_cast<std::size_t>(ranks));
      std::vector<Index> held_bonds(static_cast<std::size_t>(ranks));
      ASSERT_NO_THROW(net.run([&](int rank) {
        const OwnedRows rows{rank, owner};
        const Model part =
            discretise(scene, [&](const Model& m) { return families_to_hold(m, rows, rings); });
        held_bonds[static_cast<std::size_t>(rank)] = part.bonds.n_bonds();
        ProblemOptions options = rank_options(problem_options(scene), net, rank, owner);
        options.matrix_free = rings == 1;
        records[static_cast<std::size_t>(rank)] = break_save_restore(part, options, x, at_most);
      }));
      for (int rank = 0; rank < ranks; ++rank) {
        SCOPED_TRACE("rank " + std::to_string(rank));
        const Record& r = records[static_cast<std::size_t>(rank)];
        if (!cuts || ranks == 2) {
          EXPECT_LT(held_bonds[static_cast<std::size_t>(rank)], model.bonds.n_bonds());
        }
        ASSERT_EQ(r.rounds.size(), whole.rounds.size());
        for (std::size_t k = 0; k < r.rounds.size(); ++k) {
          EXPECT_EQ(r.rounds[k], whole.rounds[k]) << "round " << k << ": the pairs and their order";
          EXPECT_EQ(r.peaks[k].ratio, whole.peaks[k].ratio) << "round " << k;
          EXPECT_EQ(r.peaks[k].i, whole.peaks[k].i) << "round " << k;
          EXPECT_EQ(r.peaks[k].j, whole.peaks[k].j) << "round " << k;
        }
        EXPECT_EQ(r.broken, whole.broken);
        EXPECT_TRUE((r.damage.array() == whole.damage.array()).all()) << "damage, to the bit";
        EXPECT_EQ(r.fragment_particles, whole.fragment_particles);
        EXPECT_EQ(r.fragments, whole.fragments);
        for (const char* key : {"failure/broken_bonds", "failure/reference_bonds"}) {
          ASSERT_EQ(r.saved.arrays.count(key), whole.saved.arrays.count(key)) << key;
          if (whole.saved.arrays.count(key)) {
            EXPECT_EQ(r.saved.get(key), whole.saved.get(key)) << key;
          }
        }
        EXPECT_EQ(r.restored_broken, whole.broken);
        EXPECT_TRUE((r.restored_damage.array() == whole.damage.array()).all()) << "restored damage";
        EXPECT_EQ(r.restored_fragment_particles, whole.fragment_particles);
      }
    }
}

TEST(PartitionedFailure, StretchWithContactBreaksAsOneProcess) {
  // The notched plate pulled at 1.3 times the critical stretch: vertical bonds first, in
  // rounds of 7 (ties broken by the whole model's bond index), the new faces contact pairs.
  const Scene scene = test::scene_from_yaml(
      test::notch_yaml(0.0, true, "{linear: umfpack}", "contact: {friction: 0.3, radius_factor: 1.2}\n"));
  const Material& m = scene.materials.begin()->second;
  const double s_c = critical_stretch(scene.failure.G_c, bulk_modulus_2d(m), shear_modulus(m),
                                      scene.discretization.horizon_factor * scene.discretization.spacing);
  expect_ranks_break_as_one_process(scene, 1.3 * s_c, 0.0, 7);
}

TEST(PartitionedFailure, SkewBreaksAsOneProcess) {
  // Shear at 1.3 times the critical skew: the reference bonds are chosen again as theirs break,
  // on every rank that holds the family, and are saved with the whole model's indices.
  std::string yaml = test::notch_yaml(0.0, false, "{linear: umfpack}");
  yaml += "failure: {criterion: skew, G_c: 10.0, direction: [1, 0]}\n";
  const Scene scene = test::scene_from_yaml(yaml);
  const Material& m = scene.materials.begin()->second;
  const double g_c = critical_skew(scene.failure.G_c, shear_modulus(m),
                                   scene.discretization.horizon_factor * scene.discretization.spacing);
  expect_ranks_break_as_one_process(scene, 0.0, 1.3 * g_c, 5);
}

}  // namespace
}  // namespace peristat
