// The lattice census and the parts built from it (discretisation/census.hpp, model_part.hpp;
// docs/guide/distributed.md, "The partitioned model"): a rank builds its part from a few bytes
// per lattice point, never from the whole model. Each part is compared, table by table and
// exactly, with the part extract_part() cuts from the whole model with the same owners: both
// only number and copy, so any difference is a defect of the numbering.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "app/setup.hpp"
#include "discretisation/census.hpp"
#include "discretisation/lattice_partition.hpp"
#include "discretisation/model_part.hpp"
#include "support/same_part.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

struct Named {
  std::string name;
  Scene scene;
};

/// Mirror grips, fictitious layers with a pre-crack, two bodies in contact (blocks, regions),
/// and a notch held by a corner particle (a particle with one unknown).
std::vector<Named> scenes() {
  return {{"mirror plate", test::mirror_grip_plate()},
          {"cracked plate", test::slanted_crack_plate()},
          {"two plates in contact", test::scene_from_yaml(test::large_slide_yaml("1.0e-3", "friction: 0.2"))},
          {"notched plate", test::scene_from_yaml(test::notch_yaml(1e-5, true))}};
}

// The census counts what the whole model holds: its particles, unknowns, bonds and cut pairs.
TEST(Census, CountsTheWholeModel) {
  for (const Named& s : scenes()) {
    SCOPED_TRACE(s.name);
    const Model whole = discretise(s.scene);
    const LatticeCensus census = take_census(s.scene, true);
    EXPECT_EQ(census.n_particles(), whole.particles.size());
    EXPECT_EQ(census.n_unknowns(), whole.constraints.n_free);
    EXPECT_EQ(census.n_bonds(), whole.bonds.n_bonds());
    EXPECT_EQ(census.n_cut_bonds, whole.n_cut_bonds);
    // A few bytes per lattice point against the whole model's table of particles and bonds.
    EXPECT_LT(census.memory_bytes() * 20, whole.memory_bytes());
  }
}

// Every part built from the census is the part cut from the whole model with the same owners
// (LatticePartition::owner() per particle, owned_rows()), on 2, 3 and 4 ranks, both
// partitions, one and two rings, and with extra particles far from the part.
TEST(Census, PartsFromTheCensusAreThePartsOfTheWholeModel) {
  for (const Named& s : scenes()) {
    const Model whole = discretise(s.scene);
    const LatticeCensus census = take_census(s.scene, true);
    for (const BelosPartition kind : {BelosPartition::rcb, BelosPartition::strips})
      for (const int ranks : {2, 3, 4}) {
        const LatticePartition partition(census, ranks, kind);
        std::vector<int> owner;
        for (const auto& l : whole.particles.lattice) owner.push_back(partition.owner(l[0], l[1]));
        for (const int rings : {1, 2})
          for (int rank = 0; rank < ranks; ++rank) {
            SCOPED_TRACE(s.name + ", " + std::string(to_string(kind)) + " on " + std::to_string(ranks) +
                         " ranks, rank " + std::to_string(rank) + ", rings " + std::to_string(rings));
            // The extra particles: the first and the last of the model (a body's corner, a
            // condition's layer), wherever the part is.
            const std::vector<std::int64_t> extra =
                rank == 1 ? std::vector<std::int64_t>{whole.particles.size() - 1, 0} : std::vector<std::int64_t>{};
            const ModelPart built = build_part(s.scene, census, partition, rank, rings, extra);
            const ModelPart cut =
                extract_part(whole, owner, rank, families_to_hold(whole, OwnedRows{rank, owner}, rings), extra);
            ASSERT_LT(built.model.particles.size(), whole.particles.size()) << "a part, not the whole";
            test::expect_same_part(built, cut);
          }
      }
  }
}

// On one rank the part built from the census is the whole model as one part (whole_as_part(),
// what one process runs): every table the same, exactly.
TEST(Census, TheOnePartIsTheWholeModel) {
  for (const Named& s : scenes()) {
    SCOPED_TRACE(s.name);
    const LatticeCensus census = take_census(s.scene, true);
    const LatticePartition one(census, 1, BelosPartition::rcb);
    test::expect_same_part(build_part(s.scene, census, one, 0, 1), whole_as_part(discretise(s.scene)));
  }
}

// The regions tile the census box, each point in exactly one, and hold equal shares of the
// nodes to within one lattice line per cut; strips cut across x only.
TEST(LatticePartition, RegionsTileTheBoxWithEqualNodeCounts) {
  const Scene scene = test::mirror_grip_plate();  // 44 x 40 real particles, every one a node
  const LatticeCensus census = take_census(scene, false);
  for (const BelosPartition kind : {BelosPartition::rcb, BelosPartition::strips})
    for (const int parts : {2, 3, 4, 7}) {
      SCOPED_TRACE(std::string(to_string(kind)) + " into " + std::to_string(parts));
      const LatticePartition partition(census, parts, kind);
      std::vector<std::int64_t> nodes(static_cast<std::size_t>(parts), 0);
      std::int64_t total = 0;
      for (int i = census.i0; i < census.i0 + census.ni; ++i)
        for (int j = census.j0; j < census.j0 + census.nj; ++j) {
          const int r = partition.region_at(i, j);
          int holding = 0;
          for (int p = 0; p < parts; ++p) holding += partition.region(p).contains(i, j);
          ASSERT_EQ(holding, 1) << "(" << i << ", " << j << ")";
          ASSERT_TRUE(partition.region(r).contains(i, j));
          if (census.at(i, j).node()) {
            ++nodes[static_cast<std::size_t>(r)];
            ++total;
          }
        }
      ASSERT_EQ(total, 44 * 40);
      // Each cut misses its share by at most half a line (44 or 40 nodes); a region lies
      // below at most ceil(log2(7)) = 3 cuts.
      for (int p = 0; p < parts; ++p) {
        EXPECT_NEAR(static_cast<double>(nodes[static_cast<std::size_t>(p)]), static_cast<double>(total) / parts,
                    3 * 44.0 / 2)
            << "region " << p;
        if (kind == BelosPartition::strips) {
          EXPECT_EQ(partition.region(p).lo[1], census.j0);
          EXPECT_EQ(partition.region(p).hi[1], census.j0 + census.nj - 1);
        }
      }
    }
}

}  // namespace
}  // namespace peristat
