#include "core/options.hpp"

namespace peristat {

std::string_view to_string(SolverKind kind) {
  switch (kind) {
    case SolverKind::newton:
      return "newton";
    case SolverKind::adr:
      return "adr";
  }
  return "?";
}

std::string_view to_string(LinearSolverKind kind) {
  switch (kind) {
    case LinearSolverKind::cholmod:
      return "cholmod";
    case LinearSolverKind::umfpack:
      return "umfpack";
    case LinearSolverKind::klu:
      return "klu";
    case LinearSolverKind::ldlt:
      return "ldlt";
    case LinearSolverKind::cg:
      return "cg";
    case LinearSolverKind::bicgstab:
      return "bicgstab";
  }
  return "?";
}

std::string_view to_string(PreconditionerKind kind) {
  switch (kind) {
    case PreconditionerKind::automatic:
      return "auto";
    case PreconditionerKind::bond:
      return "bond";
    case PreconditionerKind::cholmod:
      return "cholmod";
    case PreconditionerKind::ic:
      return "ic";
    case PreconditionerKind::diagonal:
      return "diagonal";
    case PreconditionerKind::ilut:
      return "ilut";
  }
  return "?";
}

}  // namespace peristat
