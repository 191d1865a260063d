#include "core/options.hpp"

#include <array>

namespace peristat {

namespace {
/// The name of enum value k: names[k], in the order of the enum's declaration.
template <class Kind, std::size_t N>
std::string_view name_of(Kind kind, const std::array<std::string_view, N>& names) {
  const auto k = static_cast<std::size_t>(kind);
  return k < N ? names[k] : "?";
}
}  // namespace

std::string_view to_string(SolverKind kind) {
  return name_of(kind, std::array<std::string_view, 2>{"newton", "adr"});
}

std::string_view to_string(LinearSolverKind kind) {
  return name_of(kind,
                 std::array<std::string_view, 9>{"cholmod", "umfpack", "klu", "ldlt", "cg", "bicgstab", "belos",
                                                  "matrix_free", "auto"});
}

std::string_view to_string(PreconditionerKind kind) {
  return name_of(kind, std::array<std::string_view, 7>{"auto", "bond", "cholmod", "ic", "diagonal", "ilut", "bond_amg"});
}

std::string_view to_string(ActionFactors kind) {
  return name_of(kind, std::array<std::string_view, 4>{"auto", "double", "float", "mixed"});
}

std::string_view to_string(BelosMethod kind) {
  return name_of(kind, std::array<std::string_view, 3>{"auto", "cg", "gmres"});
}

std::string_view to_string(BelosPreconditioner kind) {
  return name_of(kind, std::array<std::string_view, 4>{"muelu", "ifpack2_ilut", "ifpack2_relaxation", "bond_factor"});
}

std::string_view to_string(BelosPartition kind) {
  return name_of(kind, std::array<std::string_view, 2>{"strips", "rcb"});
}

std::string_view to_string(BelosTangent kind) {
  return name_of(kind, std::array<std::string_view, 2>{"assembled", "matrix_free"});
}

std::string_view to_string(ContactEnforcement kind) {
  return name_of(kind, std::array<std::string_view, 2>{"penalty", "exact"});
}

std::string_view to_string(ClosureReference kind) {
  return name_of(kind, std::array<std::string_view, 3>{"spacing", "broken_bonds", "material"});
}

}  // namespace peristat
