#include "scene/scene.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include "core/geometry.hpp"
#include "scene/overrides.hpp"
#include "scene/solver_section.hpp"
#include "scene/yaml_schema.hpp"

namespace peristat {

namespace {

using schema::Field;
using schema::Map;

std::string format_point(const Vec2& p) {
  std::ostringstream s;
  s << "[" << p.x() << ", " << p.y() << "]";
  return s.str();
}

/// A body as read, plus what edge indices need: whether its polygon was reversed.
struct ParsedBody {
  Body body;
  bool reversed = false;
};

// ---- materials -------------------------------------------------------------------------

Material read_material(const Field& field) {
  const Map m = checked_map(field, {"E", "nu", "thickness", "kinematics"});
  Material mat;
  mat.name = schema::leaf(field.key());
  {
    // Forces are E times strains, volumes and spacings: beyond these bounds they underflow
    // to denormals (a solve then "converges" at rest) or overflow (extremes campaign).
    const Field e = m.require("E", "E, Young's modulus [Pa], a number > 0");
    mat.E = schema::positive(e);
    if (mat.E < 1e-100 || mat.E > 1e100)
      schema::out_of_range(e, "1e-100 <= E <= 1e100 Pa (the forces would underflow or overflow double precision)");
  }
  mat.nu = schema::in_open_range(m.require("nu", "nu, Poisson's ratio, -1 < nu < 0.5"), -1.0, 0.5);
  mat.thickness = schema::positive(m.require("thickness", "thickness [m], a number > 0"));
  if (auto f = m.find("kinematics"))
    mat.kinematics =
        schema::choice(*f, {"finite", "small"}) == "small" ? Kinematics::small : Kinematics::finite;
  mat.where = field.where();
  return mat;
}

std::map<std::string, Material> read_materials(const Field& field) {
  const Map m = named_map(field, "material");
  if (m.entries().empty())
    field.fail("expected at least one material (a map name -> {E, nu, thickness}), found none");
  std::map<std::string, Material> materials;
  for (const Field& entry : m.entries()) materials.emplace(schema::leaf(entry.key()), read_material(entry));
  return materials;
}

// ---- discretization --------------------------------------------------------------------

Quadrature read_quadrature(const Field& field) {
  const std::string q = schema::choice(field, {"isotropic", "partial", "full"});
  if (q == "partial") return Quadrature::partial;
  if (q == "full") return Quadrature::full;
  return Quadrature::isotropic;
}

SurfaceCorrectionMethod read_surface_correction(const Field& field) {
  const std::string q = schema::choice(field, {"none", "moments"});
  if (q == "moments") return SurfaceCorrectionMethod::moments;
  return SurfaceCorrectionMethod::none;
}

Discretization read_discretization(const Field& field) {
  const Map m = checked_map(
      field, {"spacing", "horizon_factor", "fictitious_layers", "quadrature", "surface_correction", "origin"});
  Discretization d;
  const Field& spacing = m.require("spacing", "spacing, the lattice spacing dx [m], a number > 0");
  d.spacing = schema::positive(spacing);
  d.spacing_where = spacing.where();
  d.horizon_where = field.where();
  d.horizon_where.key += ".horizon_factor";
  if (auto f = m.find("horizon_factor")) {
    d.horizon_factor = schema::at_least(*f, 1.0);
    d.horizon_where = f->where();
  }
  if (auto f = m.find("fictitious_layers")) d.fictitious_layers = schema::int_at_least(*f, 0);
  if (auto f = m.find("quadrature")) d.quadrature = read_quadrature(*f);
  if (auto f = m.find("surface_correction")) d.surface_correction = read_surface_correction(*f);
  if (auto f = m.find("origin")) d.origin = schema::point(*f);
  d.where = field.where();
  return d;
}

// ---- bodies ----------------------------------------------------------------------------

/// {min: [x, y], max: [x, y]} with min < max componentwise.
std::pair<Vec2, Vec2> read_box(const Field& field, std::string_view what) {
  const Map m = checked_map(field, {"min", "max"});
  const Vec2 lo = schema::point(m.require("min", "min: [x, y], the lower-left corner"));
  const Vec2 hi = schema::point(m.require("max", "max: [x, y], the upper-right corner"));
  if (!(lo.x() < hi.x() && lo.y() < hi.y()))
    field.fail("degenerate " + std::string(what) + ": expected min < max in x and in y, found min " +
               format_point(lo) + ", max " + format_point(hi));
  return {lo, hi};
}

Polygon read_rectangle(const Field& field) {
  const auto [lo, hi] = read_box(field, "rectangle");
  return Polygon{{lo, {hi.x(), lo.y()}, hi, {lo.x(), hi.y()}}};
}

void check_simple_polygon(const Field& field, const std::vector<Vec2>& v) {
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (v[k] == v[(k + 1) % v.size()])
      field.fail("vertices " + std::to_string(k) + " and " + std::to_string((k + 1) % v.size()) +
                 " coincide: expected distinct consecutive vertices");
  }
  const auto [i, j] = geometry::first_self_intersection(v);
  if (i >= 0)
    field.fail("edges " + std::to_string(i) + " and " + std::to_string(j) +
               " intersect: expected a simple polygon (edge k runs from vertex k to k+1)");
  Vec2 lo = v[0], hi = v[0];
  for (const Vec2& p : v) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  if (std::abs(geometry::signed_area(v)) <= 1e-12 * (hi - lo).squaredNorm())
    field.fail("degenerate polygon: its area is zero; expected area > 0");
}

/// The polygon counter-clockwise; `reversed` says whether the input was clockwise.
Polygon read_polygon(const Field& field, bool& reversed) {
  const std::vector<Field> items = schema::list(field);
  if (items.size() < 3)
    field.fail("expected a polygon of at least 3 vertices [[x, y], ...], found " +
               std::to_string(items.size()));
  Polygon poly;
  for (const Field& item : items) poly.vertices.push_back(schema::point(item));
  check_simple_polygon(field, poly.vertices);
  reversed = geometry::signed_area(poly.vertices) < 0.0;
  if (reversed) std::reverse(poly.vertices.begin(), poly.vertices.end());
  return poly;
}

ParsedBody read_body(const Field& field, const std::map<std::string, Material>& materials) {
  const Map m = checked_map(field, {"material", "rectangle", "polygon"});
  ParsedBody parsed;
  Body& b = parsed.body;
  b.name = schema::leaf(field.key());
  const Field material = m.require("material", "material, the name of an entry of materials");
  b.material = schema::text(material);
  if (!materials.contains(b.material)) {
    std::string known;
    for (const auto& [name, mat] : materials) known += (known.empty() ? "" : ", ") + name;
    material.fail("unknown material \"" + b.material + "\": expected one of " + known);
  }
  const auto rectangle = m.find("rectangle");
  const auto polygon = m.find("polygon");
  if (rectangle && polygon)
    polygon->fail("a body has one shape: expected exactly one of rectangle, polygon, found both");
  if (rectangle) {
    b.shape = read_rectangle(*rectangle);
    b.is_rectangle = true;
  } else if (polygon) {
    b.shape = read_polygon(*polygon, parsed.reversed);
  } else {
    field.fail("missing shape: expected exactly one of rectangle: {min, max} or polygon: [[x, y], ...]");
  }
  b.where = field.where();
  return parsed;
}

std::vector<ParsedBody> read_bodies(const Field& field, const std::map<std::string, Material>& materials) {
  const Map m = named_map(field, "body");
  if (m.entries().empty())
    field.fail("expected at least one body (a map name -> {material, rectangle | polygon}), found none");
  std::vector<ParsedBody> bodies;
  for (const Field& entry : m.entries()) bodies.push_back(read_body(entry, materials));
  return bodies;
}

// ---- cracks ----------------------------------------------------------------------------

Crack read_crack(const Field& field, const std::vector<ParsedBody>& bodies) {
  const Map m = checked_map(field, {"from", "to"});
  Crack c;
  c.a = schema::point(m.require("from", "from: [x, y], one end of the crack"));
  c.b = schema::point(m.require("to", "to: [x, y], the other end of the crack"));
  c.where = field.where();
  if (c.a == c.b) field.fail("crack has zero length: expected from != to, found both " + format_point(c.a));
  for (const ParsedBody& p : bodies)
    if (geometry::segment_touches_polygon(c.a, c.b, p.body.shape.vertices)) return c;
  field.fail("crack lies outside every body: expected a segment that meets at least one body, found " +
             format_point(c.a) + " to " + format_point(c.b));
}

// ---- boundary conditions ---------------------------------------------------------------

const ParsedBody& find_body(const Field& field, const std::vector<ParsedBody>& bodies) {
  const std::string name = schema::text(field);
  std::string known;
  for (const ParsedBody& p : bodies) {
    if (p.body.name == name) return p;
    known += (known.empty() ? "" : ", ") + p.body.name;
  }
  field.fail("unknown body \"" + name + "\": expected one of " + known);
}

/// The edge index in the stored (counter-clockwise) polygon. Indices as written refer to
/// the vertices as written; a reversed polygon maps user edge k to n - 2 - k (mod n).
int read_edge(const Field& field, const ParsedBody& p) {
  static const char* const names[] = {"bottom", "right", "top", "left"};
  const int n = static_cast<int>(p.body.shape.vertices.size());
  const std::string s = schema::text(field);
  if (p.body.is_rectangle) {
    for (int k = 0; k < 4; ++k)
      if (s == names[k]) return k;
  }
  long long k = -1;
  if (!YAML::convert<long long>::decode(field.node(), k) || k < 0 || k >= n) {
    const std::string expected = p.body.is_rectangle ? "bottom, right, top, left or 0..3"
                                                     : "an integer 0.." + std::to_string(n - 1) +
                                                           " (edge k runs from vertex k to k+1)";
    field.fail("unknown edge \"" + s + "\" of body " + p.body.name + ": expected " + expected);
  }
  const int edge = static_cast<int>(k);
  return p.reversed ? (2 * n - 2 - edge) % n : edge;
}

AffineValue read_affine(const Field& field) {
  if (field.node().IsScalar()) {
    AffineValue v;
    v.value = schema::number(field);
    return v;
  }
  if (!field.node().IsMap())
    field.fail("expected a number or {value: v, grad: [gx, gy]}, found " + field.found());
  const Map m = checked_map(field, {"value", "grad"});
  AffineValue v;
  if (auto f = m.find("value")) v.value = schema::number(*f);
  if (auto f = m.find("grad")) v.grad = schema::point(*f);
  return v;
}

void read_selector(const Map& m, const ParsedBody& body, int default_layers, BoundaryCondition& bc) {
  const auto edge = m.find("edge"), surround = m.find("surround"), region = m.find("region"),
             block = m.find("block");
  const int count = int(bool(edge)) + int(bool(surround)) + int(bool(region)) + int(bool(block));
  if (count != 1)
    m.self().fail("expected exactly one of edge, surround, region, block, found " + std::to_string(count));
  const auto layers = m.find("layers");
  bc.layers = layers ? schema::int_at_least(*layers, 0) : default_layers;
  if (edge) {
    bc.selector = BoundaryCondition::Selector::edge;
    bc.edge = read_edge(*edge, body);
    bc.edge_name = schema::text(*edge);
  } else if (surround) {
    bc.selector = BoundaryCondition::Selector::surround;
    if (!schema::boolean(*surround))
      surround->fail("surround: false selects nothing: expected true (or use edge or region)");
  } else if (region) {
    bc.selector = BoundaryCondition::Selector::region;
    if (layers) layers->fail("layers is not allowed with region (a region prescribes real particles)");
    std::tie(bc.lo, bc.hi) = read_box(*region, "region");
  } else {
    bc.selector = BoundaryCondition::Selector::block;
    if (layers) layers->fail("layers is not allowed with block (the box gives the particles)");
    std::tie(bc.lo, bc.hi) = read_box(*block, "block");
  }
}

/// k_field: {K_I, K_II, tip: [x, y], direction: [dx, dy]}: the Williams near-tip field of
/// the body's material (plane stress), ahead of the tip along `direction`.
KField read_k_field(const Field& field, const Material& material) {
  const Map m = checked_map(field, {"K_I", "K_II", "tip", "direction"});
  KField k;
  if (auto f = m.find("K_I")) k.K_I = schema::number(*f);
  if (auto f = m.find("K_II")) k.K_II = schema::number(*f);
  if (!m.find("K_I") && !m.find("K_II")) field.fail("expected at least one of K_I, K_II");
  k.tip = schema::point(m.require("tip", "tip: [x, y], the crack tip"));
  const Field dir = m.require("direction", "direction: [x, y], ahead of the tip (the crack lies behind it)");
  k.direction = schema::point(dir);
  if (!(k.direction.norm() > 0.0)) dir.fail("expected a non-zero direction, found " + dir.found());
  k.direction.normalize();
  k.mu = material.E / (2.0 * (1.0 + material.nu));
  k.kappa = (3.0 - material.nu) / (1.0 + material.nu);
  return k;
}

BoundaryCondition read_condition(const Field& field, const std::vector<ParsedBody>& bodies,
                                 const std::map<std::string, Material>& materials, int default_layers) {
  const Map m = checked_map(field, {"body", "edge", "surround", "region", "block", "layers", "mirror", "ux", "uy",
                                    "k_field"});
  BoundaryCondition bc;
  const ParsedBody& body = find_body(m.require("body", "body, the name of an entry of bodies"), bodies);
  bc.body = body.body.name;
  read_selector(m, body, default_layers, bc);
  if (auto f = m.find("mirror")) {
    bc.mirror = schema::boolean(*f);
    if (bc.mirror && bc.selector != BoundaryCondition::Selector::edge)
      f->fail("mirror needs an edge selector (it reflects the body across that edge)");
    if (bc.mirror && m.find("layers"))
      f->fail("layers is not allowed with mirror: the mirrored depth is always two stencil reaches, 2 ceil(m + 1/2) layers");
  }
  if (auto f = m.find("k_field")) {
    if (bc.mirror) f->fail("k_field is not allowed with mirror (a mirror prescribes the normal component only)");
    for (const char* other : {"ux", "uy"})
      if (auto g = m.find(other))
        g->fail(std::string(other) + " is not allowed with k_field (the field gives both components)");
    const KField k = read_k_field(*f, materials.at(body.body.material));
    bc.ux = AffineValue{0.0, Vec2::Zero(), k, 0};
    bc.uy = AffineValue{0.0, Vec2::Zero(), k, 1};
  }
  if (auto f = m.find("ux")) bc.ux = read_affine(*f);
  if (auto f = m.find("uy")) bc.uy = read_affine(*f);
  if (!bc.ux && !bc.uy) field.fail("prescribes nothing: expected at least one of ux, uy, k_field");
  bc.where = field.where();
  return bc;
}

// ---- contact ---------------------------------------------------------------------------

NormalLaw read_normal_law(const Field& field) {
  return schema::choice(field, {"paper", "pair"}) == "pair" ? NormalLaw::pair : NormalLaw::paper;
}

/// {bodies: [a, b]}: two distinct bodies of the scene; errors point at the offending name.
ContactInterface read_interface(const Field& field, const std::vector<ParsedBody>& bodies) {
  const Map m = checked_map(field, {"bodies"});
  const Field names = m.require("bodies", "bodies: [a, b], the names of two entries of bodies");
  const std::vector<Field> items = schema::list(names);
  if (items.size() != 2)
    names.fail("expected exactly two body names [a, b], found " +
               (names.node().IsSequence() ? "a list of " + std::to_string(items.size()) : names.found()));
  ContactInterface c;
  c.body_a = find_body(items[0], bodies).body.name;
  c.body_b = find_body(items[1], bodies).body.name;
  if (c.body_a == c.body_b)
    items[1].fail("body \"" + c.body_b + "\" is named twice: expected two different bodies");
  c.where = field.where();
  return c;
}

/// The section is present, so contact is on unless it says `enabled: false`.
ContactOptions read_contact(const Field& field, const std::vector<ParsedBody>& bodies) {
  const Map m =
      checked_map(field, {"enabled", "friction", "radius_factor", "normal", "stiffness", "tangential_factor",
                          "gate", "cracks", "interfaces", "friction_law", "enforcement", "stick",
                          "closure_tolerance", "max_multiplier_updates", "closure_reference"});
  ContactOptions c;
  c.enabled = true;
  if (auto f = m.find("enabled")) c.enabled = schema::boolean(*f);
  if (auto f = m.find("friction")) c.friction = schema::at_least(*f, 0.0);
  if (auto f = m.find("radius_factor")) c.radius_factor = schema::positive(*f);
  if (auto f = m.find("normal")) c.normal = read_normal_law(*f);
  if (auto f = m.find("stiffness")) c.stiffness = schema::positive(*f);
  if (auto f = m.find("tangential_factor")) c.tangential_factor = schema::positive(*f);
  if (auto f = m.find("gate")) {
    c.gate = schema::number(*f);
    if (!(c.gate >= 0.0 && c.gate < 1.0)) schema::out_of_range(*f, "0 <= gate < 1");
  }
  if (auto f = m.find("cracks")) c.cracks = schema::boolean(*f);
  if (auto f = m.find("friction_law")) {
    c.velocity_sign = schema::choice(*f, {"return_map", "velocity_sign"}) == "velocity_sign";
    c.friction_law_where = f->where();
  }
  if (auto f = m.find("enforcement")) {
    c.enforcement = schema::choice(*f, {"penalty", "exact"}) == "exact" ? ContactEnforcement::exact
                                                                        : ContactEnforcement::penalty;
    c.enforcement_where = f->where();
  } else if (c.normal == NormalLaw::pair) {
    c.enforcement = ContactEnforcement::penalty;  // the pair law has no normal to enforce
  }
  bool stick_given = false;
  if (auto f = m.find("stick")) {
    c.exact_stick = schema::choice(*f, {"exact", "penalty"}) == "exact";
    c.stick_where = f->where();
    stick_given = true;
  }
  if (stick_given && c.exact_stick && c.enforcement != ContactEnforcement::exact)
    throw InputError(c.stick_where,
                     "stick: exact needs enforcement: exact (the stick multipliers are updated with the normal ones; "
                     "docs/theory/contact.md section 8)");
  if (auto f = m.find("closure_tolerance")) {
    c.closure_tolerance = schema::number(*f);
    c.closure_tolerance_given = true;
    if (!(c.closure_tolerance > 0.0 && c.closure_tolerance < 1.0))
      schema::out_of_range(*f, "0 < closure_tolerance < 1 (a fraction of the pair's reference normal distance)");
  }
  if (auto f = m.find("max_multiplier_updates")) c.max_multiplier_updates = schema::int_at_least(*f, 1);
  if (auto f = m.find("closure_reference")) {
    const std::string r = schema::choice(*f, {"broken_bonds", "material", "spacing"});
    c.closure_reference = r == "material"       ? ClosureReference::material
                          : r == "broken_bonds" ? ClosureReference::broken_bonds
                                                : ClosureReference::spacing;
    c.closure_reference_where = f->where();
    if (c.enforcement != ContactEnforcement::exact)
      throw InputError(
          c.closure_reference_where,
          "closure_reference needs enforcement: exact (the penalty law has no closure tolerance to "
          "measure from it; docs/theory/contact.md section 8)");
  }
  if (c.enforcement == ContactEnforcement::exact && c.normal == NormalLaw::pair)
    throw InputError(c.enforcement_where,
                     "enforcement: exact needs normal: paper (it enforces the gap along the interface normal; "
                     "the pair law has none, docs/theory/contact.md)");
  if (auto f = m.find("interfaces"))
    for (const Field& item : schema::list(*f)) c.interfaces.push_back(read_interface(item, bodies));
  c.where = field.where();
  return c;
}

// ---- loading, solver, output -----------------------------------------------------------

Loading read_loading(const Field& field) {
  const Map m = checked_map(field, {"steps", "max_cutbacks", "max_resolves", "predictor"});
  Loading l;
  if (auto f = m.find("steps")) l.steps = schema::int_at_least(*f, 1);
  if (auto f = m.find("max_cutbacks")) l.max_cutbacks = schema::int_at_least(*f, 0);
  if (auto f = m.find("predictor")) l.extrapolate = schema::choice(*f, {"extrapolate", "previous"}) == "extrapolate";
  if (auto f = m.find("max_resolves")) l.max_resolves = schema::int_at_least(*f, 0);
  return l;
}

FailureOptions read_failure(const Field& field) {
  const Map m = checked_map(field, {"criterion", "G_c", "direction", "fraction", "skew_min_angle", "skew_scale"});
  FailureOptions o;
  o.enabled = true;
  o.criterion =
      schema::choice(m.require("criterion", "criterion: stretch | skew"), {"stretch", "skew"}) == "skew"
          ? FailureCriterion::skew
          : FailureCriterion::stretch;
  o.G_c = schema::positive(m.require("G_c", "G_c, the critical energy release rate [J/m^2]"));
  if (auto f = m.find("direction")) {
    o.direction = schema::point(*f);
    if (o.direction.norm() == 0.0) schema::out_of_range(*f, "a non-zero direction [x, y]");
  } else if (o.criterion == FailureCriterion::skew) {
    field.fail(
        "criterion skew needs direction: [x, y], the reference direction of the skew (e.g. the crack's)");
  }
  if (auto f = m.find("fraction")) {
    o.fraction = schema::number(*f);
    if (!(o.fraction > 0.0 && o.fraction <= 1.0)) schema::out_of_range(*f, "0 < fraction <= 1");
  }
  if (auto f = m.find("skew_min_angle")) {
    if (o.criterion != FailureCriterion::skew)
      f->fail("skew_min_angle applies to criterion skew only (the criterion is stretch)");
    o.skew_min_angle = schema::number(*f);
    if (!(o.skew_min_angle >= 0.0 && o.skew_min_angle < 90.0))
      schema::out_of_range(*f, "0 <= skew_min_angle < 90 [degrees] (0 is the paper's eq 22)");
  }
  if (auto f = m.find("skew_scale")) {
    if (o.criterion != FailureCriterion::skew)
      f->fail("skew_scale applies to criterion skew only (the criterion is stretch)");
    o.skew_scale = schema::positive(*f);
  }
  o.where = field.where();
  return o;
}

OutputOptions read_output(const Field& field) {
  const Map m = checked_map(field, {"every"});
  OutputOptions o;
  if (auto f = m.find("every")) o.every = schema::int_at_least(*f, 1);
  return o;
}

// ---- the scene -------------------------------------------------------------------------

std::string read_name(const Field& field) {
  const std::string name = schema::text(field);
  const bool ok = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-';
  });
  if (!ok)
    field.fail("invalid name \"" + name +
               "\": expected letters, digits, '_', '.' and '-' only "
               "(results are written to <out>/<name>.h5)");
  return name;
}

void read_sections(const Map& top, Scene& scene) {
  scene.name = read_name(top.require("name", "name, the run name [A-Za-z0-9_.-]+"));
  scene.materials = read_materials(top.require("materials", "materials, a map name -> {E, nu, thickness}"));
  scene.discretization =
      read_discretization(top.require("discretization", "discretization, a map with at least spacing"));
  const std::vector<ParsedBody> bodies = read_bodies(
      top.require("bodies", "bodies, a map name -> {material, rectangle | polygon}"), scene.materials);
  for (const ParsedBody& p : bodies) scene.bodies.push_back(p.body);
  if (auto f = top.find("cracks"))
    for (const Field& item : schema::list(*f)) scene.cracks.push_back(read_crack(item, bodies));
  if (auto f = top.find("boundary"))
    for (const Field& item : schema::list(*f))
      scene.boundary.push_back(read_condition(item, bodies, scene.materials, scene.discretization.fictitious_layers));
  if (auto f = top.find("contact")) scene.contact = read_contact(*f, bodies);
  if (auto f = top.find("failure")) scene.failure = read_failure(*f);
  if (auto f = top.find("loading")) scene.loading = read_loading(*f);
  if (auto f = top.find("solver")) scene.solver = read_solver(*f);
  if (auto f = top.find("output")) scene.output = read_output(*f);
  if (scene.solver.newton.atol < 0.0) {  // not given: scaled with the stiffest material
    double force_unit = 0.0;
    for (const auto& [name, material] : scene.materials)
      force_unit = std::max(force_unit, material.E * material.thickness * scene.discretization.spacing);
    scene.solver.newton.atol = kAtolPerForceUnit * force_unit;
  }
  if (scene.contact.enabled && scene.contact.velocity_sign && scene.solver.type != SolverKind::adr) {
    throw InputError(scene.contact.friction_law_where,
                     "friction_law: velocity_sign needs solver.type: adr (a static Newton solve has no "
                     "velocity; it uses the return map, docs/theory/contact.md)");
  }
}

Scene read_scene(const Field& root) {
  if (root.node().IsNull())
    root.fail("the scene is empty: expected a map with at least name, materials, discretization, bodies");
  const Map top = checked_map(root, {"name", "materials", "discretization", "bodies", "cracks", "boundary",
                                     "contact", "failure", "loading", "solver", "output"});
  Scene scene;
  read_sections(top, scene);
  return scene;
}

/// Records where each document of a YAML text starts (its root node, else the document
/// marker), building nothing.
class DocumentStarts : public YAML::EventHandler {
 public:
  std::vector<YAML::Mark> marks;
  void OnDocumentStart(const YAML::Mark& mark) override {
    marks.push_back(mark);
    m_root_pending = true;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { node(mark); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { node(mark); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override {
    node(mark);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    node(mark);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    node(mark);
  }
  void OnMapEnd() override {}

 private:
  void node(const YAML::Mark& mark) {
    if (m_root_pending && !marks.empty()) marks.back() = mark;
    m_root_pending = false;
  }
  bool m_root_pending = false;
};

/// The one YAML document of `text`; syntax errors become InputError at their line.
/// Documents are counted one at a time rather than by YAML::LoadAll: yaml-cpp 0.7 never
/// consumes a ',' outside a flow collection at the start of a document and returns empty
/// documents at the same place forever (`peristat check` on a file starting with ',' hung,
/// tests/fuzz/crashes/scene/timeout-7b176a32...).
YAML::Node load_document(const std::string& text, const std::string& path) {
  DocumentStarts starts;
  YAML::Node first;
  try {
    std::istringstream in(text);
    YAML::Parser parser(in);
    while (parser.HandleNextDocument(starts)) {
      const std::vector<YAML::Mark>& m = starts.marks;
      if (m.size() >= 2 && m[m.size() - 1].pos == m[m.size() - 2].pos)
        throw InputError(SourceLocation{path, m.back().line + 1, ""},
                         "YAML syntax error: unexpected text at column " +
                             std::to_string(m.back().column + 1) + " (a ',' outside [ ] or { }?)");
    }
    if (starts.marks.size() == 1) first = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(SourceLocation{path, e.mark.line + 1, ""}, "YAML syntax error: " + e.msg);
  }
  if (starts.marks.size() > 1)
    throw InputError(SourceLocation{path, starts.marks[1].line + 1, ""},
                     "found " + std::to_string(starts.marks.size()) + " YAML documents: expected one");
  return starts.marks.empty() ? YAML::Node(YAML::NodeType::Null) : first;
}

std::string emit(const YAML::Node& root) {
  YAML::Emitter out;
  out << root;
  return std::string(out.c_str()) + "\n";
}

}  // namespace

Scene parse_scene_text(const std::string& text, const std::string& path,
                       const std::vector<Override>& overrides) {
  schema::Source source{path, {}};
  YAML::Node root = load_document(text, path);
  for (const Override& o : overrides) apply_override(root, o, source);
  const int line = root.Mark().line >= 0 ? root.Mark().line + 1 : 1;
  Scene scene = read_scene(Field(source, root, "", line));
  scene.path = path;
  scene.text = emit(root);
  return scene;
}

Scene parse_scene(const std::string& path, const std::vector<Override>& overrides) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec))
    throw InputError(SourceLocation{path, 0, ""}, "cannot read the scene file: no such file");
  if (!fs::is_regular_file(path, ec))
    throw InputError(SourceLocation{path, 0, ""}, "cannot read the scene file: not a regular file");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in) throw InputError(SourceLocation{path, 0, ""}, "cannot read the scene file");
  return parse_scene_text(text.str(), path, overrides);
}

}  // namespace peristat
