// The discrete model: particles on a uniform lattice, bond families (CSR), prescribed
// components. Built once by discretise() from a ModelDescription (a Scene is one); no
// physics here.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "core/description.hpp"
#include "core/types.hpp"
#include "discretisation/lattice_index.hpp"

namespace peristat {

/// Particles of every body, real and fictitious. Lattice point (i, j) sits at
/// origin + ((i + 1/2) dx, (j + 1/2) dx).
struct Particles {
  std::vector<Vec2> position;               ///< reference position X
  std::vector<double> volume;               ///< dx^2 * thickness [m^3]
  std::vector<int> body;                    ///< index into ModelDescription::bodies
  std::vector<char> fictitious;             ///< 1 for fictitious boundary-layer particles
  std::vector<std::array<int, 2>> lattice;  ///< integer lattice coordinates
  Index size() const { return static_cast<Index>(position.size()); }
};

/// The bond stencil of the uniform lattice: lattice offsets inside the horizon and the area
/// weight of each (docs/theory/osb.md, "Quadrature").
struct Stencil {
  std::vector<std::array<int, 2>> offset;
  std::vector<double> weight;  ///< area of the neighbour cell seen from the centre [m^2]
  int reach = 0;               ///< max |offset component|
  double beta = 0.0;           ///< the fourth-harmonic correction used (isotropic quadrature)
};

Stencil make_stencil(double horizon_factor, double spacing, Quadrature quadrature);

/// Layers of a mirror condition: two stencil reaches, so that every ghost bonded to a real
/// particle has its whole family.
int mirror_layers(double horizon_factor);

/// Bond families in CSR form: the bonds of particle i are start[i] .. start[i+1]-1.
/// Bonds are symmetric: reverse(i, b) is the index of the bond j -> i for b = i -> j. The
/// reference bond vector X_j - X_i is not stored (16 bytes per bond): Model::xi() computes
/// it from the positions, the same bits every time.
///
/// A family with every bond of the stencil (a whole family: the interior, most of a model)
/// lists them in stencil order. Two facts follow that spare the interior 12 bytes per bond:
/// its weights are the stencil's, and the reverse of its k-th bond, when the neighbour's
/// family is whole too, is that family's bond of the mirrored offset, start[j] + mirror[k].
/// The other families (cut by an edge, a pre-crack, another body or a rank's part, and the
/// whole ones next to them for the reverse) keep their own. A weight is the quadrature area of
/// the neighbour seen from the centre [m^2] (Stencil::weight).
struct Bonds {
  std::vector<Index> start;
  std::vector<Index> neighbour;
  std::vector<double> stencil_weight;  ///< Stencil::weight: a whole family's weights
  std::vector<Index> own_start{0};     ///< N + 1 (CSR): the weights of the other families
  std::vector<double> own_weight;
  std::vector<Index> stencil_mirror;        ///< per stencil index k, the index of -offset[k]
  std::vector<Index> own_reverse_start{0};  ///< N + 1 (CSR): the reverses kept
  std::vector<Index> own_reverse;
  Index n_bonds() const { return static_cast<Index>(neighbour.size()); }
  Index family_size(Index i) const { return start[i + 1] - start[i]; }
  /// Particle i's bond weights, in its family's order.
  std::span<const double> weights(Index i) const {
    const Index o = own_start[static_cast<std::size_t>(i)],
                n = own_start[static_cast<std::size_t>(i) + 1] - o;
    return n == family_size(i) ? std::span<const double>(own_weight)
                                     .subspan(static_cast<std::size_t>(o), static_cast<std::size_t>(n))
                               : std::span<const double>(stencil_weight);
  }
  /// Bond b's weight, b one of particle i's bonds.
  double weight(Index i, Index b) const { return weights(i)[static_cast<std::size_t>(b - start[i])]; }
  /// The bond j -> i of bond b = i -> j, b one of particle i's bonds; -1 when j's family is
  /// not held (a rank's part).
  Index reverse(Index i, Index b) const {
    const auto o = static_cast<std::size_t>(own_reverse_start[static_cast<std::size_t>(i)]);
    const Index k = b - start[i];
    return static_cast<std::size_t>(own_reverse_start[static_cast<std::size_t>(i) + 1]) != o
               ? own_reverse[o + static_cast<std::size_t>(k)]
               : start[neighbour[b]] + stencil_mirror[static_cast<std::size_t>(k)];
  }
  /// Keeps `every` (each bond's reverse, in bond order) where reverse() cannot compute it;
  /// throws std::logic_error where it computes another. stencil_mirror first.
  void set_reverse(std::span<const Index> every);
  /// Appends the next particle's weights (families in particle order, after its bonds).
  void add_weights(std::span<const double> w);
  /// Every bond's weight in bond order (8 bytes per bond: transient copies and tests).
  std::vector<double> every_weight() const;
};

/// A fictitious particle of a mirror condition and the real particle it reflects:
/// u_c(ghost) = sign[c] u_c(source) + lambda value_c(ghost) (docs/theory/osb.md, section 7).
struct MirrorImage {
  Index ghost = -1, source = -1;
  std::array<double, 2> sign{1.0, 1.0};
};

/// Prescribed displacement components: dof 2p + c (c = 0 for x, 1 for y). A component of a
/// mirror ghost counts as prescribed (it is not an unknown); its value is the affine part
/// and its image adds sign * u(source).
struct Constraints {
  std::vector<char> prescribed;   ///< 2N flags
  std::vector<double> value;      ///< 2N values at load factor 1
  std::vector<Index> free_index;  ///< 2N: index among the unknowns, or -1 if prescribed
  Index n_free = 0;
  std::vector<std::vector<Index>> condition_dofs;  ///< per boundary condition, the components it prescribes
  std::vector<MirrorImage> images;  ///< mirror ghosts, sorted by source (empty: no mirror)
  std::vector<Index> image_start;   ///< N + 1 (CSR by source particle) when images exist
  bool has_images() const { return !images.empty(); }

  // The one map between the unknowns x (n_free) and full vectors over every component (2N).
  /// u = x on free components, lambda times the prescribed value on the others.
  void expand(const VectorXd& x, double lambda, VectorXd& u) const;
  /// full = x on free components, 0 on the others.
  void scatter(const VectorXd& x, VectorXd& full) const;
  /// x = the free components of full.
  void gather(const VectorXd& full, VectorXd& x) const;
};

/// A body as the solver sees it: its name, its material, its reference shape.
struct BodyInfo {
  std::string name;
  Material material;
  Polygon shape;
};

struct Model {
  Particles particles;
  Stencil stencil;
  Bonds bonds;
  Constraints constraints;
  double spacing = 0.0;
  double horizon = 0.0;
  Index n_cut_bonds = 0;         ///< bonds removed by pre-cracks (counted once per pair)
  std::vector<BodyInfo> bodies;  ///< per body, in ModelDescription::bodies order (particles' body index)
  std::vector<Crack> cracks;     ///< the pre-crack segments
  LatticeIndex lattice_index;    ///< lattice point -> particle
  /// Per particle: 1 when its family is held. Empty: every family (one process, or a rank
  /// holding the whole model). A rank of a distributed run with partitioned bonds holds the
  /// families it evaluates only (docs/guide/distributed.md, "Failure on the parts"); the others
  /// are empty, and a held family's bond to a particle whose family is not held has no
  /// reverse (-1).
  std::vector<char> family_held;
  /// Directed bonds of the whole model (bonds.n_bonds() when every family is held): 64 bits, as
  /// a model whose ranks hold its bonds in parts may have more than 2^31 (45M particles at m = 3).
  std::int64_t n_bonds_whole = 0;
  /// With family_held (partitioned bonds): the whole model's family starts (N + 1), so that
  /// bond k of particle i's family has the whole model's index whole_start[i] + k on every
  /// rank (a broken bond's identity in a checkpoint). Empty when every family is held. On a
  /// rank's part (ModelPart) entry i is particle i's in the part's order, so the entries do not
  /// increase and whole_start[i + 1] is not where i's family ends.
  std::vector<std::int64_t> whole_start;

  bool holds_every_family() const { return family_held.empty(); }

  /// Bond b's reference vector X_j - X_i, b one of particle i's bonds.
  Vec2 xi(Index i, Index b) const { return particles.position[bonds.neighbour[b]] - particles.position[i]; }
  /// The reference vectors of particle i's family, in a buffer of the calling thread's that
  /// the thread's next call overwrites (it grows to the largest family once).
  std::span<const Vec2> family_xi(Index i) const;

  /// Bytes held by the particles, bonds, constraints and lattice index.
  std::size_t memory_bytes() const;
};

/// Builds the model. Throws InputError (with the condition's or body's location) when
/// bodies overlap, a condition selects no particle, or two conditions prescribe the same
/// component of one particle.
Model discretise(const ModelDescription& scene);

/// The particles within the stencil of a particle in `seeds` (the seeds among them): a
/// superset of the seeds and their bond neighbours, from lattice offsets alone.
std::vector<char> within_stencil(const Model& model, const std::vector<char>& seeds);

/// True when segment [p, q] crosses the crack [a, b] (docs/theory/osb.md, "Pre-cracks").
bool bond_crosses_crack(const Vec2& p, const Vec2& q, const Vec2& a, const Vec2& b);

/// Crossing-number point-in-polygon test with a half-open rule, so a lattice point on an
/// edge shared by two polygons belongs to exactly one of them.
bool inside_polygon(const Polygon& polygon, const Vec2& p);

}  // namespace peristat
