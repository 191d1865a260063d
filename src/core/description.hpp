// The model a scene describes, as plain data: materials, bodies, pre-cracks, boundary
// conditions and the lattice. src/scene parses it from YAML (Scene derives from
// ModelDescription); discretise() builds the particles and bonds from it, and the physics
// (materials, contact) reads Material, Polygon and Crack from here, not from the scene.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/k_field.hpp"
#include "core/types.hpp"

namespace peristat {

enum class Kinematics { finite, small };

struct Material {
  std::string name;
  double E = 0.0;                              ///< Young's modulus [Pa], > 0, required
  double nu = 0.0;                             ///< Poisson's ratio, in (-1, 0.5), required
  double thickness = 0.0;                      ///< plate thickness [m], > 0, required
  Kinematics kinematics = Kinematics::finite;  ///< "finite" (default) or "small"
  SourceLocation where;
};

/// A closed polygon, vertices counter-clockwise (the parser reorders clockwise input).
/// Edge k runs from vertices[k] to vertices[(k+1) % n].
struct Polygon {
  std::vector<Vec2> vertices;
};

struct Body {
  std::string name;
  std::string material;  ///< key into Scene::materials
  Polygon shape;
  /// For a `rectangle:` body the edges are also named: bottom = 0, right = 1, top = 2,
  /// left = 3 (the counter-clockwise order from the lower-left corner).
  bool is_rectangle = false;
  SourceLocation where;
};

/// A pre-crack: every bond whose segment crosses [a, b] is cut before the first step.
struct Crack {
  Vec2 a = Vec2::Zero();
  Vec2 b = Vec2::Zero();
  SourceLocation where;
};

/// A prescribed displacement component at load factor 1: value + grad . X (X = reference
/// position), plus component `k_component` of a K-field when the condition has one
/// (`k_field:`). The applied value at load factor lambda is lambda times this.
struct AffineValue {
  double value = 0.0;
  Vec2 grad = Vec2::Zero();
  std::optional<KField> k;
  int k_component = 0;
  double at(const Vec2& X) const { return value + grad.dot(X) + (k ? k->at(X)[k_component] : 0.0); }
};

/// A prescribed-displacement condition.
///  - selector edge: `layers` fictitious layers of particles are added outside the named
///    edge of the body (lattice points outside the polygon, within layers*dx of the edge
///    line, projecting inside the edge) and the given components are prescribed on them.
///  - selector surround: fictitious particles everywhere outside the body within
///    layers*dx of its boundary (corners included); used by patch tests.
///  - layers 0 (edge or surround): no fictitious particles; the body's own particles within
///    one spacing inside the edge line (or the boundary) are prescribed (docs/theory/osb.md,
///    section 7: a grip on the body's surface).
///  - mirror (edge only): fictitious layers two stencil reaches deep (2 ceil(m + 1/2) layers)
///    that reflect the body across the edge line: the normal component is
///    u_n(ghost) = 2 U - u_n(image), the tangential one u_t(ghost) = u_t(image), with U the
///    one prescribed (normal) component. The edge is a frictionless rigid platen and a
///    symmetry plane (docs/theory/osb.md, section 7).
///  - selector region: real particles of the body inside the box [lo, hi]; no layers.
///  - selector block: fictitious particles of the body at the lattice points inside the box
///    [lo, hi] that no body holds (e.g. the paper's fixed 3 x 3 corner block); no layers.
struct BoundaryCondition {
  enum class Selector { edge, surround, region, block };
  std::string body;
  Selector selector = Selector::edge;
  int edge = -1;          ///< polygon edge index (selector edge)
  std::string edge_name;  ///< as written: "left", "3", ... (for messages)
  int layers = 3;         ///< fictitious layers (default discretization.fictitious_layers)
  bool mirror = false;    ///< mirrored layers (selector edge; see above)
  Vec2 lo = Vec2::Zero(), hi = Vec2::Zero();  ///< selectors region and block
  std::optional<AffineValue> ux, uy;          ///< at least one is set
  SourceLocation where;
};

/// How bond weights (the volume of the neighbour seen from a particle) are integrated.
///  - isotropic (default): partial areas of the neighbour cell inside the horizon disc,
///    corrected by a fixed factor (1 + beta cos 4 phi) so that the square-lattice stencil
///    integrates the fourth moments of the bond direction exactly (docs/theory/osb.md).
///  - partial: partial areas only.  - full: whole cell if its centre is inside the horizon.
enum class Quadrature { isotropic, partial, full };
/// discretization.surface_correction (docs/theory/osb.md, section 8).
enum class SurfaceCorrectionMethod { none, moments };

struct Discretization {
  double spacing = 0.0;         ///< dx [m], > 0, required
  double horizon_factor = 3.0;  ///< m: delta = m * dx, >= 1
  int fictitious_layers = 3;    ///< default layer count of edge conditions, >= 1
  Quadrature quadrature = Quadrature::isotropic;
  SurfaceCorrectionMethod surface_correction = SurfaceCorrectionMethod::moments;
  Vec2 origin = Vec2::Zero();  ///< lattice points sit at origin + (i + 1/2, j + 1/2) dx
  SourceLocation where;
  SourceLocation spacing_where, horizon_where;  ///< of the two keys (the section's when absent)
};

/// What discretise() reads: the part of a Scene that describes the model.
struct ModelDescription {
  std::map<std::string, Material> materials;
  std::vector<Body> bodies;
  std::vector<Crack> cracks;
  std::vector<BoundaryCondition> boundary;
  Discretization discretization;
};

}  // namespace peristat
