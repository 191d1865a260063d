// A rank's part of the model (discretisation/model_part.hpp; docs/guide/distributed.md, "The
// partitioned model: what each rank holds"): a Model of its own, owned particles first, whose kernels give
// the whole model's rows. The parts of P emulated ranks are taken from one whole model and
// compared with it entry by entry.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "app/setup.hpp"
#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"
#include "parallel/thread_ranks.hpp"
#include "support/finite_difference.hpp"
#include "support/owners.hpp"
#include "support/same_part.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

/// Owners by height: the nodes in `ranks` bands of equal count across y (the other direction
/// from strips and x cuts, so that a part's ring crosses the mirror layers of both grips).
std::vector<int> y_cut_owners(const Model& model, int ranks) {
  std::vector<int> owner = test::x_cut_owners(model, 1);  // -1 for the particles without an unknown
  std::vector<Index> nodes;
  for (Index p = 0; p < model.particles.size(); ++p)
    if (owner[static_cast<std::size_t>(p)] >= 0) nodes.push_back(p);
  std::stable_sort(nodes.begin(), nodes.end(), [&](Index a, Index b) {
    return model.particles.position[a].y() < model.particles.position[b].y();
  });
  for (std::size_t k = 0; k < nodes.size(); ++k)
    owner[static_cast<std::size_t>(nodes[k])] =
        static_cast<int>(k * static_cast<std::size_t>(ranks) / nodes.size());
  return owner;
}

struct Split {
  std::string name;
  std::vector<int> owner;
};

std::vector<int> completed(const Model& model, std::vector<int> owner) {
  test::complete_owners(model, owner);
  return owner;
}

/// Owners of the nodes only (every part holds every particle without a row, as the parts of
/// ranks whose owners have -1), and owners of every particle (test::complete_owners(); a run's
/// are LatticePartition's regions, tests/unit/test_census.cpp).
std::vector<Split> splits(const Model& model) {
  return {{"strips on 2 ranks", test::strip_owners(model.constraints, 2)},
          {"strips on 3 ranks", test::strip_owners(model.constraints, 3)},
          {"cuts across y on 2 ranks", y_cut_owners(model, 2)},
          {"cuts across y on 4 ranks", y_cut_owners(model, 4)},
          {"strips on 3 ranks, every particle owned", completed(model, test::strip_owners(model.constraints, 3))},
          {"cuts across y on 4 ranks, every particle owned", completed(model, y_cut_owners(model, 4))}};
}

int ranks_of(const std::vector<int>& owner) {
  return 1 + *std::max_element(owner.begin(), owner.end());
}

// The parts hold the whole model: each particle with unknowns is owned by one part, and
// every particle, component, constraint and held bond of a part is the whole model's entry at
// its global index. A property of the numbering alone, checked exactly.
void expect_parts_map_onto_the_whole(const Model& whole) {
  const Constraints& wc = whole.constraints;
  for (const Split& split : splits(whole)) {
    SCOPED_TRACE(split.name);
    const int ranks = ranks_of(split.owner);
    std::vector<int> owned_by(static_cast<std::size_t>(whole.particles.size()), 0);
    Index unknowns = 0;
    for (int rank = 0; rank < ranks; ++rank) {
      SCOPED_TRACE("rank " + std::to_string(rank));
      const OwnedRows rows{rank, split.owner};
      const ModelPart part = extract_part(whole, split.owner, rank, families_to_hold(whole, rows, 1));
      const Model& m = part.model;
      ASSERT_EQ(part.global_id.size(), static_cast<std::size_t>(m.particles.size()));
      ASSERT_LT(m.particles.size(), whole.particles.size()) << "a part holds fewer particles than the model";
      EXPECT_LT(m.bonds.n_bonds(), whole.bonds.n_bonds());
      EXPECT_EQ(m.n_bonds_whole, whole.bonds.n_bonds());
      EXPECT_EQ(m.n_cut_bonds, whole.n_cut_bonds);
      EXPECT_EQ(part.n_unknowns_whole, wc.n_free);
      for (Index l = 0; l < m.particles.size(); ++l) {
        const auto g = static_cast<Index>(part.global_id[static_cast<std::size_t>(l)]);
        const bool own = split.owner[static_cast<std::size_t>(g)] == rank;
        ASSERT_EQ(own, l < part.n_owned) << "owned particles first, particle " << l;
        owned_by[static_cast<std::size_t>(g)] += own;
        ASSERT_EQ(m.particles.position[l], whole.particles.position[g]);
        ASSERT_EQ(m.particles.volume[l], whole.particles.volume[g]);
        ASSERT_EQ(m.particles.body[l], whole.particles.body[g]);
        ASSERT_EQ(m.particles.fictitious[l], whole.particles.fictitious[g]);
        ASSERT_EQ(m.lattice_index.at(m.particles.lattice[l][0], m.particles.lattice[l][1]), l);
        for (int c = 0; c < 2; ++c) {
          ASSERT_EQ(m.constraints.prescribed[2 * l + c], wc.prescribed[2 * g + c]);
          ASSERT_EQ(m.constraints.value[2 * l + c], wc.value[2 * g + c]);
          const Index f = m.constraints.free_index[2 * l + c];
          ASSERT_EQ(f >= 0, wc.free_index[2 * g + c] >= 0);
          if (f >= 0) {
            ASSERT_EQ(part.global_unknown[static_cast<std::size_t>(f)], wc.free_index[2 * g + c]);
            ASSERT_EQ(f < part.n_owned_unknowns, own) << "owned unknowns first";
          }
        }
        if (!m.family_held[static_cast<std::size_t>(l)]) continue;
        ASSERT_EQ(m.bonds.family_size(l), whole.bonds.family_size(g)) << "a held family is whole";
        for (Index k = 0; k < m.bonds.family_size(l); ++k) {
          const Index b = m.bonds.start[l] + k, wb = whole.bonds.start[g] + k;
          ASSERT_EQ(part.global_id[static_cast<std::size_t>(m.bonds.neighbour[b])],
                    whole.bonds.neighbour[wb]);
          ASSERT_EQ(m.xi(l, b), whole.xi(g, wb));
          ASSERT_EQ(m.bonds.weight(l, b), whole.bonds.weight(g, wb));
          const Index r = m.bonds.reverse(l, b);
          ASSERT_EQ(r >= 0, m.family_held[static_cast<std::size_t>(m.bonds.neighbour[b])] != 0);
          if (r >= 0) {
            ASSERT_EQ(m.bonds.reverse(m.bonds.neighbour[b], r), b);
          }
        }
      }
      for (const MirrorImage& im : m.constraints.images) {
        const auto g = part.global_id[static_cast<std::size_t>(im.ghost)];
        const auto it = std::find_if(wc.images.begin(), wc.images.end(),
                                     [&](const MirrorImage& w) { return w.ghost == g; });
        ASSERT_NE(it, wc.images.end());
        EXPECT_EQ(part.global_id[static_cast<std::size_t>(im.source)], it->source);
        EXPECT_EQ(im.sign, it->sign);
      }
      unknowns += part.n_owned_unknowns;
    }
    EXPECT_EQ(unknowns, wc.n_free) << "the parts own every unknown once";
    for (Index g = 0; g < whole.particles.size(); ++g)
      EXPECT_EQ(owned_by[static_cast<std::size_t>(g)], split.owner[static_cast<std::size_t>(g)] >= 0 ? 1 : 0)
          << "particle " << g;
  }
}

/// Calls check(problem, part, xl) on every rank's part of every split (ranks emulated by
/// threads): the part holds `rings` rings of families, its problem has `options` with the
/// part's rows and global ids and load factor 1, and xl holds `x`'s entries of the part's
/// unknowns (no ghost import: each part is handed the whole state's entries of all of them).
template <class Check>
void on_every_part(const Model& whole, int rings, const ProblemOptions& options, const VectorXd& x,
                   const Check& check) {
  for (const Split& split : splits(whole)) {
    SCOPED_TRACE(split.name);
    ThreadNet net(ranks_of(split.owner));
    net.run([&](const ThreadRanks& on) {
      const int rank = on.rank();
      SCOPED_TRACE("rank " + std::to_string(rank));
      const ModelPart part = extract_part(whole, split.owner, rank,
                                          families_to_hold(whole, OwnedRows{rank, split.owner}, rings));
      ProblemOptions part_options = options;
      part_options.rows = OwnedRows{rank, part.owner};
      part_options.global_id = part.global_id;  // the part's share of the contact pairs
      part_options.n_particles_whole = part.n_particles_whole;
      QuasiStaticProblem problem(part.model, part_options, on);
      problem.set_load_factor(1.0);
      VectorXd xl(part.model.constraints.n_free);
      for (Index f = 0; f < xl.size(); ++f) xl[f] = x[part.global_unknown[static_cast<std::size_t>(f)]];
      check(problem, part, xl);
    });
  }
}

// Each part's problem, evaluated at the whole state's entries of its unknowns, gives the
// whole model's residual in its owned rows, bit for bit (each row sums its families' forces
// in the same bond order), and the matrix-free action of the tangent in its owned rows to
// round-off (its chunks of families are the part's, so a row's terms are added in another
// order: 1e-16 of the largest entry measured, 1e-13 allowed). The force scale, summed over the parts as the
// ranks would sum it, is the whole one's to round-off.
void expect_part_rows_equal_the_whole(const Scene& scene) {
  const Model whole = discretise(scene);
  ProblemOptions options = problem_options(scene);
  options.matrix_free = true;
  QuasiStaticProblem whole_problem(whole, options);
  whole_problem.set_load_factor(1.0);
  const VectorXd x = test::random_vector(whole.constraints.n_free, 2e-6, 31u);
  const VectorXd direction = test::random_vector(whole.constraints.n_free, 1.0, 32u);
  VectorXd r_whole, y_whole;
  SparseMatrix none;
  whole_problem.evaluate(x, r_whole, &none);
  whole_problem.apply_tangent(direction, y_whole);
  ASSERT_GT(r_whole.norm(), 0.0);
  const double y_scale = y_whole.cwiseAbs().maxCoeff();
  on_every_part(
      whole, 1, options, x, [&](QuasiStaticProblem& problem, const ModelPart& part, const VectorXd& xl) {
        const Index n = part.model.constraints.n_free;
        VectorXd v(n), r, y, r_own;
        problem.evaluate(1.3 * xl, r, &none);  // first elsewhere: nothing may be left from it
        problem.evaluate(xl, r, &none);
        v.setConstant(std::numeric_limits<double>::quiet_NaN());  // the action reads its ghosts only
        for (const Index f : problem.action_reads())
          v[f] = direction[part.global_unknown[static_cast<std::size_t>(f)]];
        problem.apply_tangent(v, y);
        ASSERT_TRUE(problem.set_evaluation_mode(EvaluationMode::own_rows_only));
        problem.evaluate(xl, r_own, nullptr);
        for (Index f = 0; f < part.n_owned_unknowns; ++f) {
          const auto g = part.global_unknown[static_cast<std::size_t>(f)];
          ASSERT_EQ(r[f], r_whole[g]) << "residual, owned unknown " << f << " (whole " << g << ")";
          ASSERT_EQ(r_own[f], r_whole[g]) << "own-rows residual, owned unknown " << f;
          ASSERT_NEAR(y[f], y_whole[g], 1e-13 * y_scale) << "action, owned unknown " << f;
        }
        for (Index f = part.n_owned_unknowns; f < n; ++f) EXPECT_EQ(r_own[f], 0.0) << "another rank's row";
        // force_norm(): the ranks' own squares summed in rank order, with the particles without a
        // row once (round-off of another order of summation: 1e-13 relative).
        EXPECT_NEAR(problem.force_scale(), whole_problem.force_scale(), 1e-13 * whole_problem.force_scale());
      });
}

// The assembled tangent and the bond preconditioner on the parts (belos `assembled`, ADR's
// density): a part then holds two rings of families, and its matrices hold its owned rows
// only, each the whole matrix's row entry for entry (the same columns, by global unknown).
// The values to round-off: a part adds a row's terms family by family in its own particle
// order (1e-13 of the largest entry allowed; the whole matrices' rows-split predecessor of
// this test found them equal to the bit, and a wrong or missing family is off by O(1)).
void expect_part_matrices_equal_the_whole(const Scene& scene) {
  using RowMajor = Eigen::SparseMatrix<double, Eigen::RowMajor>;
  const Model whole = discretise(scene);
  const ProblemOptions options = problem_options(scene);  // an assembled tangent
  QuasiStaticProblem whole_problem(whole, options);
  whole_problem.set_load_factor(1.0);
  const VectorXd x = test::random_vector(whole.constraints.n_free, 2e-6, 33u);
  SparseMatrix K = whole_problem.make_tangent(), P = whole_problem.make_preconditioner();
  VectorXd r;
  whole_problem.evaluate(x, r, &K);
  whole_problem.assemble_preconditioner(P);
  const RowMajor Kw = K, Pw = P;
  const double k_scale = K.coeffs().abs().maxCoeff(), p_scale = P.coeffs().abs().maxCoeff();
  ASSERT_GT(k_scale, 0.0);
  on_every_part(
      whole, 2, options, x, [&](QuasiStaticProblem& problem, const ModelPart& part, const VectorXd& xl) {
        const Index n = part.model.constraints.n_free;
        VectorXd rl;
        SparseMatrix Kl = problem.make_tangent(), Pl = problem.make_preconditioner();
        problem.evaluate(1.3 * xl, rl, &Kl);  // first elsewhere: nothing may be left from it
        problem.evaluate(xl, rl, &Kl);
        problem.assemble_preconditioner(Pl);
        for (const auto& [whole_m, part_m, scale, what] :
             {std::tuple{&Kw, RowMajor(Kl), k_scale, "tangent"},
              std::tuple{&Pw, RowMajor(Pl), p_scale, "bond preconditioner"}}) {
          long long entries = 0;
          for (Index f = 0; f < n; ++f) {
            const auto g = part.global_unknown[static_cast<std::size_t>(f)];
            std::vector<std::pair<std::int64_t, double>> mine, theirs;
            for (RowMajor::InnerIterator it(part_m, f); it; ++it)
              mine.emplace_back(part.global_unknown[static_cast<std::size_t>(it.col())], it.value());
            entries += static_cast<long long>(mine.size());
            if (f >= part.n_owned_unknowns) {
              ASSERT_TRUE(mine.empty()) << what << ": another rank's row " << f << " holds entries";
              continue;
            }
            for (RowMajor::InnerIterator it(*whole_m, static_cast<Index>(g)); it; ++it)
              theirs.emplace_back(it.col(), it.value());
            std::sort(mine.begin(), mine.end());
            ASSERT_EQ(mine.size(), theirs.size())
                << what << ", owned unknown " << f << " (whole " << g << ")";
            for (std::size_t e = 0; e < mine.size(); ++e) {
              ASSERT_EQ(mine[e].first, theirs[e].first) << what << ", row " << g;
              ASSERT_NEAR(mine[e].second, theirs[e].second, 1e-13 * scale)
                  << what << " (" << g << ", " << mine[e].first << ")";
            }
          }
          EXPECT_GT(entries, 0) << what << ": the part owns rows";
        }
      });
}

TEST(ModelPart, PartMatricesAreTheWholeRowsWithMirrorGrips) {
  expect_part_matrices_equal_the_whole(test::mirror_grip_plate());
}

TEST(ModelPart, PartMatricesAreTheWholeRowsWithAPreCrack) {
  expect_part_matrices_equal_the_whole(test::slanted_crack_plate());
}

/// The cracked plate pressed across its crack: the faces are contact candidates (friction 0.3).
Scene cracked_plate_with_contact() {
  Scene scene = test::slanted_crack_plate();
  scene.contact.enabled = true;
  scene.contact.cracks = true;
  scene.contact.friction = 0.3;
  return scene;
}

TEST(ModelPart, PartRowsAreTheWholeRowsWithContact) {
  // Stage 3 (docs/guide/distributed.md, "Contact on the parts"): a part holds the pairs that
  // touch its own particles, in the whole model's order and orientation, so its owned rows
  // add the same pair forces in the same order: the residual bit for bit, the action (with
  // the pairs' Jacobians) to round-off. Some pairs must carry a force at the state tested.
  const Scene scene = cracked_plate_with_contact();
  const Model whole = discretise(scene);
  QuasiStaticProblem probe(whole, problem_options(scene));
  probe.set_load_factor(1.0);
  VectorXd r;
  probe.evaluate(test::random_vector(whole.constraints.n_free, 2e-6, 31u), r, nullptr);
  ASSERT_NE(probe.contact(), nullptr);
  const ContactCounts& c = probe.contact()->counts();
  std::printf("%ld candidate pairs: %ld stick, %ld slip\n", long(c.candidates), long(c.stick), long(c.slip));
  ASSERT_GT(c.active(), 0) << "pairs must carry a force for this test to mean anything";
  expect_part_rows_equal_the_whole(scene);
}

TEST(ModelPart, PartsMapOntoTheWholeModelWithMirrorGrips) {
  const Model whole = discretise(test::mirror_grip_plate());
  ASSERT_TRUE(whole.constraints.has_images());
  expect_parts_map_onto_the_whole(whole);
}

TEST(ModelPart, PartsMapOntoTheWholeModelWithAPreCrack) {
  const Model whole = discretise(test::slanted_crack_plate());
  ASSERT_GT(whole.n_cut_bonds, 0);
  expect_parts_map_onto_the_whole(whole);
}

TEST(ModelPart, PartRowsAreTheWholeRowsWithMirrorGrips) {
  expect_part_rows_equal_the_whole(test::mirror_grip_plate());
}

TEST(ModelPart, PartRowsAreTheWholeRowsWithAPreCrack) {
  expect_part_rows_equal_the_whole(test::slanted_crack_plate());
}

TEST(ModelPart, OwnedLayersLeaveEachPartTheLayersNearIt) {
  // Every particle without a row owned by one rank (complete_owners()): a part holds the mirror
  // layers near its own particles, not both grips' whole layers. On four bands across y of the
  // mirror plate every part must shrink; measured: 1896 -> 1516 particles of the largest part.
  const Model whole = discretise(test::mirror_grip_plate());
  const std::vector<int> nodes_only = y_cut_owners(whole, 4), every = completed(whole, nodes_only);
  for (int rank = 0; rank < 4; ++rank) {
    const ModelPart before =
        extract_part(whole, nodes_only, rank, families_to_hold(whole, {rank, nodes_only}, 1));
    const ModelPart after = extract_part(whole, every, rank, families_to_hold(whole, {rank, every}, 1));
    EXPECT_LT(after.model.particles.size(), before.model.particles.size()) << "rank " << rank;
    EXPECT_LT(after.model.bonds.n_bonds(), before.model.bonds.n_bonds()) << "rank " << rank;
    std::printf("rank %d: %d -> %d particles, %d -> %d bonds\n", rank, before.model.particles.size(),
                after.model.particles.size(), before.model.bonds.n_bonds(), after.model.bonds.n_bonds());
  }
}

// One process runs its whole model as one part (whole_as_part: the model moved in, not
// copied). It must be exactly the part extract_part() cuts for one rank owning every particle
// and holding every family, so that one process and a rank take the same paths: every table
// compared entry for entry (exact: both only copy).
TEST(ModelPart, TheWholeModelAsOnePartIsTheOneRankPart) {
  for (const Scene& scene : {test::mirror_grip_plate(), test::slanted_crack_plate()}) {
    const Model whole = discretise(scene);
    const auto n = static_cast<std::size_t>(whole.particles.size());
    const ModelPart cut = extract_part(whole, std::vector<int>(n, 0), 0, std::vector<char>(n, 1));
    Model copy = whole;
    const ModelPart moved = whole_as_part(std::move(copy));
    test::expect_same_part(moved, cut);
    const Model& a = moved.model;
    EXPECT_FALSE(a.holds_every_family()) << "held family by family, as a rank's part";
  }
}

TEST(ModelPart, RefusesAnOwnedParticleWhoseFamilyIsNotHeld) {
  const Model whole = discretise(test::slanted_crack_plate());
  const std::vector<int> owner = test::strip_owners(whole.constraints, 2);
  std::vector<char> held = families_to_hold(whole, OwnedRows{0, owner}, 1);
  const auto owned = std::find(owner.begin(), owner.end(), 0) - owner.begin();
  held[static_cast<std::size_t>(owned)] = 0;
  EXPECT_THROW(extract_part(whole, owner, 0, held), std::logic_error);
}

}  // namespace
}  // namespace peristat
