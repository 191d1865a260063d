// Bond failure on the ranks' parts (docs/guide/distributed.md, "Failure on the parts"): each
// rank holds some families only and proposes the pairs of its own families;
// the candidates over the criterion, the damage and the pieces of the bond graph are
// gathered over the ranks. Ranks emulated by threads (ThreadRanks) must take one
// process's decisions bit for bit: the same pairs broken in the same order round by round,
// the same peak, damage, fragments and checkpoint, and the checkpoint restored on the ranks
// must give the same state again.
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <omp.h>

#include "app/setup.hpp"
#include "assembly/pattern.hpp"
#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"
#include "materials/failure.hpp"
#include "materials/fragments.hpp"
#include "materials/osb.hpp"
#include "parallel/exchange.hpp"
#include "parallel/thread_ranks.hpp"
#include "support/owners.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

struct Record {
  std::vector<std::vector<std::pair<Index, Index>>> rounds;
  std::vector<BondFailure::Peak> peaks;
  Index broken = 0, fragment_particles = 0, fragments = 0;
  long graph_searches = 0;  ///< after the rounds (the construction's included)
  VectorXd damage;
  StateArchive saved;
  Index restored_broken = 0, restored_fragment_particles = 0;
  VectorXd restored_damage;
  // A further round at 1.5 x, undone (what load stepping does when the re-solve fails).
  Index undone_round = 0, broken_after_undo = 0, contact_pairs_before = 0, contact_pairs_after = 0;
  bool residual_restored = false;
};

/// Breaks the bonds over the criterion at x in rounds of at most `at_most` pairs, committing
/// each, until a round breaks none; then saves the state and restores it into a fresh problem
/// (from the archive `restore_from` gives: on parts, rank 0's, which alone holds the whole
/// model's per-particle arrays, as a checkpoint file is read by every rank).
Record break_save_restore(
    const Model& model, const ProblemOptions& options, const VectorXd& x, Index at_most,
    const Ranks& ranks = serial_ranks(),
    const std::function<const StateArchive&(const StateArchive&)>& restore_from =
        [](const StateArchive& a) -> const StateArchive& { return a; }) {
  Record rec;
  QuasiStaticProblem problem(model, options, ranks);
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
  rec.graph_searches = problem.fragment_graph_searches();
  rec.saved.arrays.clear();
  problem.save_state(rec.saved);
  QuasiStaticProblem fresh(model, options, ranks);
  fresh.restore_state(restore_from(rec.saved), x);
  rec.restored_broken = fresh.failure()->broken();
  rec.restored_damage = fresh.damage();
  rec.restored_fragment_particles = fresh.fragment_particles();
  // The restored state, a round at a larger displacement, and the round undone: the problem
  // must be the restored one again, bit for bit (on a part: every rank alike, collectively).
  VectorXd before, after;
  fresh.evaluate(x, before, nullptr);
  if (fresh.contact()) rec.contact_pairs_before = fresh.contact()->size();
  rec.undone_round = fresh.advance_irreversible_state(1.5 * x, 0);
  fresh.revert_irreversible_state();
  fresh.evaluate(x, after, nullptr);
  rec.residual_restored = (before.array() == after.array()).all();
  rec.broken_after_undo = fresh.failure()->broken();
  if (fresh.contact()) rec.contact_pairs_after = fresh.contact()->size();
  return rec;
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

/// On the ranks' parts of the model (ModelPart: each rank its particles, the ring it reads, a
/// part's own indices): the same decisions as one process, by the whole model's indices. A
/// part's rounds are the whole rounds' pairs of which it holds a direction, in the same order;
/// the peaks, the counts and the checkpoint are the whole ones; the damage of every particle
/// whose family the part holds is the whole one's to the bit.
void expect_parts_break_as_one_process(const Scene& scene, const Model& model, const VectorXd& x,
                                       Index at_most, const Record& whole, const std::vector<int>& owner,
                                       int ranks) {
  ThreadNet net(ranks);
  std::vector<Record> records(static_cast<std::size_t>(ranks));
  std::vector<ModelPart> parts(static_cast<std::size_t>(ranks));
  StateArchive root_saved;
  ASSERT_NO_THROW(net.run([&](const ThreadRanks& on) {
    const int rank = on.rank();
    const OwnedRows rows{rank, owner};
    ModelPart& part = parts[static_cast<std::size_t>(rank)];
    part = extract_part(model, owner, rank, families_to_hold(model, rows, 1));
    ProblemOptions options = problem_options(scene);
    set_part(options, part, rank);
    options.matrix_free = true;
    VectorXd xl(part.model.constraints.n_free);
    for (Index f = 0; f < xl.size(); ++f) xl[f] = x[part.global_unknown[static_cast<std::size_t>(f)]];
    records[static_cast<std::size_t>(rank)] = break_save_restore(
        part.model, options, xl, at_most, on, [&](const StateArchive& mine) -> const StateArchive& {
          if (rank == 0) root_saved = mine;
          (void)on.sum(0.0);  // rank 0's archive is complete before any rank reads it
          return root_saved;
        });
  }));
  for (int rank = 0; rank < ranks; ++rank) {
    SCOPED_TRACE("part of rank " + std::to_string(rank));
    const Record& r = records[static_cast<std::size_t>(rank)];
    const ModelPart& part = parts[static_cast<std::size_t>(rank)];
    EXPECT_LT(part.model.particles.size(), model.particles.size()) << "a part, not the whole model";
    std::map<std::int64_t, Index> local;
    for (std::size_t l = 0; l < part.global_id.size(); ++l) local[part.global_id[l]] = static_cast<Index>(l);
    const auto held = [&](Index g) {
      const auto it = local.find(g);
      return it != local.end() && part.model.family_held[static_cast<std::size_t>(it->second)];
    };
    ASSERT_EQ(r.rounds.size(), whole.rounds.size());
    std::size_t pairs_held = 0;
    for (std::size_t k = 0; k < r.rounds.size(); ++k) {
      std::vector<std::pair<Index, Index>> expected, got;
      for (const auto& [i, j] : whole.rounds[k])
        if (held(i) || held(j)) expected.emplace_back(i, j);
      for (const auto& [i, j] : r.rounds[k])
        got.emplace_back(static_cast<Index>(part.global_id[static_cast<std::size_t>(i)]),
                         static_cast<Index>(part.global_id[static_cast<std::size_t>(j)]));
      EXPECT_EQ(got, expected) << "round " << k << ": the pairs the part holds, in the whole round's order";
      pairs_held += got.size();
      EXPECT_EQ(r.peaks[k].ratio, whole.peaks[k].ratio) << "round " << k;
      EXPECT_EQ(r.peaks[k].i, whole.peaks[k].i) << "round " << k;
      EXPECT_EQ(r.peaks[k].j, whole.peaks[k].j) << "round " << k;
      EXPECT_EQ(r.peaks[k].at, whole.peaks[k].at) << "round " << k;
    }
    EXPECT_GT(pairs_held, 0u);
    EXPECT_EQ(r.broken, whole.broken);
    EXPECT_EQ(r.fragment_particles, whole.fragment_particles);
    EXPECT_EQ(r.fragments, whole.fragments);
    Index compared = 0;
    for (std::size_t l = 0; l < part.global_id.size(); ++l) {
      // A particle whose family the part does not hold has its owner's damage (the exchange).
      const auto g = static_cast<Index>(part.global_id[l]);
      if (!part.model.family_held[l] && part.owner[l] < 0) continue;  // neither held nor exchanged
      ASSERT_EQ(r.damage[static_cast<Index>(l)], whole.damage[g]) << "damage of particle " << g;
      ASSERT_EQ(r.restored_damage[static_cast<Index>(l)], whole.damage[g])
          << "restored damage of particle " << g;
      ++compared;
    }
    EXPECT_GE(compared, part.n_owned);
    EXPECT_EQ(r.saved.get("failure/broken_bonds"), whole.saved.get("failure/broken_bonds"));
    if (whole.saved.arrays.count("failure/reference_bonds")) {
      if (rank == 0) {
        EXPECT_EQ(r.saved.get("failure/reference_bonds"), whole.saved.get("failure/reference_bonds"));
      }
    }
    EXPECT_EQ(r.restored_broken, whole.broken);
    EXPECT_EQ(r.restored_fragment_particles, whole.fragment_particles);
    EXPECT_EQ(r.undone_round, whole.undone_round) << "the round to undo, every rank's count";
    EXPECT_TRUE(r.residual_restored) << "the part's residual after the round was undone";
    EXPECT_EQ(r.broken_after_undo, whole.broken);
    EXPECT_EQ(r.contact_pairs_after, r.contact_pairs_before) << "the round's contact pairs dropped";
  }
}

/// The notched plate with contact on the new faces (friction 0.3), broken by stretch.
Scene notch_with_contact() {
  return test::scene_from_yaml(
      test::notch_yaml(0.0, true, "{linear: umfpack}", "contact: {friction: 0.3, radius_factor: 1.2}\n"));
}

/// The scene's critical stretch (its first material, its horizon).
double critical_stretch_of(const Scene& scene) {
  const Material& m = scene.materials.begin()->second;
  return critical_stretch(scene.failure.G_c, bulk_modulus_2d(m), shear_modulus(m),
                          scene.discretization.horizon_factor * scene.discretization.spacing);
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
  // One process searches the bond graph only after rounds whose pairs may split it (a pair's
  // particles without a common intact neighbour): fewer searches than rounds, and still the
  // fragment the parts find, which search after every round.
  EXPECT_GE(whole.graph_searches, 2) << "at the start, and after the round that cut the particle loose";
  EXPECT_LT(whole.graph_searches, static_cast<long>(whole.rounds.size()))
      << "rounds that cannot split skip it";
  EXPECT_EQ(whole.restored_broken, whole.broken);
  EXPECT_TRUE((whole.restored_damage.array() == whole.damage.array()).all());
  ASSERT_GT(whole.undone_round, 0) << "the round to undo must break bonds";
  EXPECT_TRUE(whole.residual_restored);
  EXPECT_EQ(whole.broken_after_undo, whole.broken);
  EXPECT_EQ(whole.contact_pairs_after, whole.contact_pairs_before);
  for (const auto& [cuts, ranks] : {std::pair{false, 2}, std::pair{true, 2}, std::pair{true, 3}}) {
    SCOPED_TRACE(std::string("parts, ") + (cuts ? "cuts across x" : "strips") + " on " +
                 std::to_string(ranks) + " ranks");
    expect_parts_break_as_one_process(
        scene, model, x, at_most, whole,
        cuts ? test::x_cut_owners(model, ranks) : test::strip_owners(model.constraints, ranks), ranks);
  }
}

// The pieces of the bond graph on the ranks' parts (fragments.cpp, find_unsupported_on_part):
// the notched plate with every bond cut that crosses the edge of three islands. A (x 12-28 mm,
// y 5-11 mm) straddles every cut of 2 and 3 ranks and holds the notch's tip, which cuts it
// partly inside; B (3-7 mm, 13-17 mm) lies on rank 0 alone; D is the top edge's fictitious
// layers over x 15-25 mm, prescribed in both directions (so no rank owns them: every rank holds
// them alike), and two blocks below them, x 15-19 and 21-25 mm from y 15 mm, joined to each
// other only through the layers, on either side of the 2-rank cut. One process finds A and B
// without support and D with it. Each rank joins its own families'
// bonds, links its pieces to the owners' across the parts, and must find every particle it
// holds (its own and those it reads) as one process does, with one label per component over
// every rank.
TEST(PartitionedFailure, PiecesAcrossThePartsAreThoseOfOneProcess) {
  std::string yaml = test::notch_yaml(0.0, true, "{linear: umfpack}");
  const std::size_t top = yaml.find("edge: top, uy:");
  ASSERT_NE(top, std::string::npos);
  yaml.replace(top, 14, "edge: top, ux: 0.0, uy:");
  const Scene scene = test::scene_from_yaml(yaml);
  const Model model = discretise(scene);
  // Island k of each rectangle (x0, x1, y0, y1): A, B, then D's layers and its two blocks.
  const std::array<std::array<double, 4>, 5> islands = {{{0.012, 0.028, 0.005, 0.011},
                                                         {0.003, 0.007, 0.013, 0.017},
                                                         {0.015, 0.025, 0.02, 0.03},
                                                         {0.015, 0.019, 0.015, 0.02},
                                                         {0.021, 0.025, 0.015, 0.02}}};
  const auto island = [&](const Vec2& X) {
    for (std::size_t k = 0; k < islands.size(); ++k) {
      const auto& r = islands[k];
      if (X.x() > r[0] && X.x() < r[1] && X.y() > r[2] && X.y() < r[3])
        return std::min(static_cast<int>(k), 2);
    }
    return -1;
  };
  Index unowned_in_d = 0;
  for (Index p = 0; p < model.particles.size(); ++p)
    unowned_in_d += island(model.particles.position[p]) == 2 && model.constraints.free_index[2 * p] < 0 &&
                    model.constraints.free_index[2 * p + 1] < 0;
  ASSERT_GT(unowned_in_d, 10) << "D's layers must have no unknown";
  const auto cut = [&](const Model& m) {  // the intact weights: the bonds across an island's edge cut
    std::vector<double> intact = m.bonds.every_weight();
    for (Index i = 0; i < m.particles.size(); ++i)
      for (Index b = m.bonds.start[i]; b < m.bonds.start[i + 1]; ++b)
        if (island(m.particles.position[i]) != island(m.particles.position[m.bonds.neighbour[b]]))
          intact[b] = 0.0;
    return intact;
  };
  std::vector<char> unsupported;
  std::vector<Index> component;
  find_unsupported(model, cut(model), unsupported, component);
  std::vector<int> in_island(3, 0), unsupported_in(3, 0);
  for (Index p = 0; p < model.particles.size(); ++p) {
    const int k = island(model.particles.position[p]);
    if (k >= 0) {
      ++in_island[static_cast<std::size_t>(k)];
      unsupported_in[static_cast<std::size_t>(k)] += unsupported[p];
    } else {
      ASSERT_FALSE(unsupported[p]) << "the plate outside the islands is held";
    }
  }
  // What makes the comparison mean something: two islands loose, one held through its edge.
  ASSERT_GT(in_island[0], 50);
  EXPECT_EQ(unsupported_in[0], in_island[0]);
  EXPECT_EQ(unsupported_in[1], in_island[1]);
  EXPECT_EQ(unsupported_in[2], 0);
  for (const auto& [cuts, ranks] : {std::pair{true, 2}, std::pair{true, 3}, std::pair{false, 2}}) {
    SCOPED_TRACE(std::string(cuts ? "cuts across x" : "strips") + " on " + std::to_string(ranks) + " ranks");
    const std::vector<int> owner =
        cuts ? test::x_cut_owners(model, ranks) : test::strip_owners(model.constraints, ranks);
    ThreadNet net(ranks);
    std::vector<ModelPart> parts(static_cast<std::size_t>(ranks));
    std::vector<std::vector<char>> part_unsupported(static_cast<std::size_t>(ranks));
    std::vector<std::vector<Index>> part_component(static_cast<std::size_t>(ranks));
    ASSERT_NO_THROW(net.run([&](const ThreadRanks& on) {
      const int rank = on.rank();
      const OwnedRows rows{rank, owner};
      ModelPart& part = parts[static_cast<std::size_t>(rank)];
      part = extract_part(model, owner, rank, families_to_hold(model, rows, 1));
      std::vector<char> counted;
      for (const int o : part.owner) counted.push_back(counted_by(o, rank));
      OwnedEntriesExchange exchange(on, part.global_id, part.owner, static_cast<std::size_t>(part.n_owned));
      const GraphParts graph{on, counted, part.global_id, part.owner, &exchange};
      find_unsupported(part.model, cut(part.model), part_unsupported[static_cast<std::size_t>(rank)],
                       part_component[static_cast<std::size_t>(rank)], &graph);
    }));
    std::map<Index, std::int64_t> label_of;  // a whole component -> the parts' label
    std::map<std::int64_t, Index> component_of;
    for (int rank = 0; rank < ranks; ++rank) {
      SCOPED_TRACE("rank " + std::to_string(rank));
      const ModelPart& part = parts[static_cast<std::size_t>(rank)];
      for (std::size_t l = 0; l < part.global_id.size(); ++l) {
        const auto g = static_cast<Index>(part.global_id[l]);
        ASSERT_EQ(part_unsupported[static_cast<std::size_t>(rank)][l], unsupported[g]) << "particle " << g;
        const std::int64_t label = part_component[static_cast<std::size_t>(rank)][l];
        const auto [it, fresh] = label_of.emplace(component[g], label);
        ASSERT_EQ(it->second, label) << "one label per component, particle " << g;
        const auto [jt, new_label] = component_of.emplace(label, component[g]);
        ASSERT_EQ(jt->second, component[g]) << "one component per label, particle " << g;
      }
    }
  }
}

TEST(PartitionedFailure, StretchWithContactBreaksAsOneProcess) {
  // The notched plate pulled at 1.3 times the critical stretch: vertical bonds first, in
  // rounds of 7 (ties broken by the whole model's bond index), the new faces contact pairs.
  const Scene scene = notch_with_contact();
  const double s_c = critical_stretch_of(scene);
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

// One process gathers the pairs over the criterion on its threads, block by block of 256
// particles (bond_failure.cpp, gather_candidates): the notched plate's 800 particles make
// four blocks, whose candidates and peaks are joined by one loop's rule. On 1, 2 and 3 threads
// the same pairs break in the same rounds of 7 (ties broken by the whole bond index) with the
// same peak, bit for bit.
TEST(PartitionedFailure, OneProcessBreaksAlikeOnAnyNumberOfThreads) {
  const Scene scene = notch_with_contact();
  const double s_c = critical_stretch_of(scene);
  const Model model = discretise(scene);
  ASSERT_GT(model.particles.size(), 3 * 256) << "several blocks of particles";
  const VectorXd x = affine_state(model, 1.3 * s_c, 0.0, nearest_particle(model, Vec2(0.0255, 0.0125)));
  const int saved = omp_get_max_threads();
  std::vector<Record> runs;
  for (const int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    runs.push_back(break_save_restore(model, problem_options(scene), x, 7));
  }
  omp_set_num_threads(saved);
  ASSERT_GE(runs[0].rounds.size(), 4u);
  for (std::size_t t = 1; t < runs.size(); ++t) {
    SCOPED_TRACE(std::to_string(t + 1) + " threads");
    EXPECT_EQ(runs[t].rounds, runs[0].rounds);
    ASSERT_EQ(runs[t].peaks.size(), runs[0].peaks.size());
    for (std::size_t r = 0; r < runs[0].peaks.size(); ++r) {
      EXPECT_EQ(runs[t].peaks[r].ratio, runs[0].peaks[r].ratio) << "round " << r;
      EXPECT_EQ(runs[t].peaks[r].i, runs[0].peaks[r].i) << "round " << r;
      EXPECT_EQ(runs[t].peaks[r].j, runs[0].peaks[r].j) << "round " << r;
    }
  }
}

}  // namespace
}  // namespace peristat
