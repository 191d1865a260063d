// One comparison of two parts of a model, table by table and exactly (for the parts' tests:
// parts built or cut in two ways that only number and copy must agree entry for entry).
#pragma once

#include <gtest/gtest.h>

#include "discretisation/model_part.hpp"

namespace peristat::test {

inline void expect_same_part(const ModelPart& a, const ModelPart& b) {
  EXPECT_EQ(a.n_owned, b.n_owned);
  EXPECT_EQ(a.n_owned_unknowns, b.n_owned_unknowns);
  EXPECT_EQ(a.n_particles_whole, b.n_particles_whole);
  EXPECT_EQ(a.n_unknowns_whole, b.n_unknowns_whole);
  EXPECT_EQ(a.global_id, b.global_id);
  EXPECT_EQ(a.owner, b.owner);
  EXPECT_EQ(a.global_unknown, b.global_unknown);
  const Model &x = a.model, &y = b.model;
  EXPECT_EQ(x.particles.position, y.particles.position);
  EXPECT_EQ(x.particles.volume, y.particles.volume);
  EXPECT_EQ(x.particles.body, y.particles.body);
  EXPECT_EQ(x.particles.fictitious, y.particles.fictitious);
  EXPECT_EQ(x.particles.lattice, y.particles.lattice);
  EXPECT_EQ(x.family_held, y.family_held);
  EXPECT_EQ(x.whole_start, y.whole_start);
  EXPECT_EQ(x.n_bonds_whole, y.n_bonds_whole);
  EXPECT_EQ(x.n_cut_bonds, y.n_cut_bonds);
  EXPECT_EQ(x.bonds.start, y.bonds.start);
  EXPECT_EQ(x.bonds.neighbour, y.bonds.neighbour);
  if (x.bonds.start == y.bonds.start)
    for (Index i = 0; i < x.particles.size(); ++i)
      for (Index k = x.bonds.start[i]; k < x.bonds.start[i + 1]; ++k) {
        EXPECT_EQ(x.bonds.reverse(i, k), y.bonds.reverse(i, k));
      }
  EXPECT_EQ(x.bonds.every_weight(), y.bonds.every_weight());
  const Constraints &c = x.constraints, &d = y.constraints;
  EXPECT_EQ(c.prescribed, d.prescribed);
  EXPECT_EQ(c.value, d.value);
  EXPECT_EQ(c.free_index, d.free_index);
  EXPECT_EQ(c.n_free, d.n_free);
  EXPECT_EQ(c.condition_dofs, d.condition_dofs);
  EXPECT_EQ(c.image_start, d.image_start);
  ASSERT_EQ(c.images.size(), d.images.size());
  for (std::size_t k = 0; k < c.images.size(); ++k) {
    EXPECT_EQ(c.images[k].ghost, d.images[k].ghost);
    EXPECT_EQ(c.images[k].source, d.images[k].source);
    EXPECT_EQ(c.images[k].sign, d.images[k].sign);
  }
  for (Index p = 0; p < x.particles.size(); ++p)
    ASSERT_EQ(x.lattice_index.at(x.particles.lattice[p][0], x.particles.lattice[p][1]), p);
}

}  // namespace peristat::test
