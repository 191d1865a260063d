// The validated description of a run: plain data, no physics.
// parse_scene() turns a YAML scene file (plus --set overrides) into a Scene or throws
// InputError naming file, line and key. docs/guide/scene.md documents every key.
#pragma once

#include <string>
#include <vector>

#include "core/description.hpp"
#include "core/error.hpp"
#include "core/options.hpp"
#include "core/types.hpp"

namespace peristat {

/// The solver options of a scene (solver.*): which solver, and each one's own options.
struct SolverOptions {
  SolverKind type = SolverKind::newton;
  LinearOptions linear;
  NewtonOptions newton;
  AdrOptions adr;
  BondPreconditionerOptions bond_preconditioner;  ///< solver.krylov.bond_radius
  ActionFactors action_factors = ActionFactors::automatic;  ///< solver.krylov.factors
  SourceLocation factors_where;                             ///< of solver.krylov.factors, when given
};

struct OutputOptions {
  int every = 1;  ///< write every k-th converged step (the last is always written)
};

/// A scene: the model it describes (ModelDescription: materials, bodies, cracks, boundary,
/// discretization) and how to run it.
struct Scene : ModelDescription {
  std::string name;  ///< results are DIR/<name>.h5; [A-Za-z0-9_.-]+
  std::string path;  ///< the scene file
  std::string text;  ///< the scene as run (YAML, after --set overrides)
  Loading loading;
  ContactOptions contact;
  FailureOptions failure;
  SolverOptions solver;
  OutputOptions output;
};

/// One --set override, "dotted.key=value"; value is parsed as YAML (scalar or flow list).
struct Override {
  std::string key;
  std::string value;
};

/// Parse, apply overrides, validate. Throws InputError (file, line, key, what was expected).
/// Shapes are checked here (degenerate or self-intersecting polygons, a crack that meets no
/// body). Checks that need the lattice (a condition selecting no particle, overlapping
/// bodies) are done by the discretisation, which also throws InputError with the
/// condition's or body's SourceLocation.
Scene parse_scene(const std::string& path, const std::vector<Override>& overrides = {});

/// Same from text already in memory; `path` is used in messages only.
Scene parse_scene_text(const std::string& text, const std::string& path,
                       const std::vector<Override>& overrides = {});

/// "a.b.c=value" -> Override; throws InputError on a missing '='.
Override parse_override(const std::string& assignment);

}  // namespace peristat
