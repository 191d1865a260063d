// The preconditioner choice of solver.belos (solver.belos.preconditioner): MueLu's smoothed
// aggregation, Ifpack2's additive Schwarz (ILUT or symmetric Gauss-Seidel), or a CHOLMOD
// factor of each rank's block of the bond matrix. Part of the Trilinos adapter (C++17).
#pragma once

#include <Eigen/CholmodSupport>

#include <Ifpack2_Preconditioner.hpp>
#include <MueLu_TpetraOperator.hpp>
#include <Teuchos_ParameterList.hpp>

#include "core/options.hpp"
#include "solvers/trilinos/tpetra_adapter.hpp"

namespace peristat::tpetra {

/// Additive Schwarz with a CHOLMOD factor of each rank's diagonal block of the bond matrix
/// (the `cg` path's preconditioner, on one rank exactly that factor).
class BlockFactor final : public op_t {
 public:
  explicit BlockFactor(RCP<const map_t> map);
  /// Factorises this rank's block of P (P's rows and columns in the unknowns' numbering);
  /// padding rows get `padding` on the diagonal. False when the block is not positive definite.
  bool factorize(const SparseMatrix& P, const Distribution& d, double padding);

  RCP<const map_t> getDomainMap() const override { return m_map; }
  RCP<const map_t> getRangeMap() const override { return m_map; }
  void apply(const mv_t& X, mv_t& Y, Teuchos::ETransp mode, double alpha, double beta) const override;

 private:
  RCP<const map_t> m_map;
  std::vector<Eigen::Triplet<double, Index>> m_triplets;
  SparseMatrix m_block;
  Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower> m_factor;
  Index m_pattern_nonzeros = -1;
  mutable VectorXd m_in, m_out;
};

/// The preconditioner that solver.belos.preconditioner names, built on a TpetraCopy and kept
/// (with what a rebuild of the same pattern reuses: Ifpack2's initialised Schwarz, the block
/// factor's symbolic analysis) until the next pattern.
class BelosPreconditioners {
 public:
  /// The built preconditioner, or null.
  const RCP<op_t>& get() const { return m_preconditioner; }
  /// Drops the built preconditioner (before a set-up: the old hierarchy goes first); with
  /// `pattern` (a new pattern) also what a rebuild would reuse.
  void drop(bool pattern);
  /// Builds `kind` for `copy`'s matrix; `P` (the bond matrix in the unknowns' numbering) for
  /// bond_factor, `muelu_parameters` overriding the MueLu defaults. Success, InvalidInput
  /// (bond_factor without P), or NumericalIssue (a Trilinos failure, e.g. a zero pivot).
  Eigen::ComputationInfo build(BelosPreconditioner kind, const TpetraCopy& copy, const UnknownLayout& layout,
                               const Teuchos::ParameterList& muelu_parameters, const SparseMatrix* P);

 private:
  void build_muelu(const TpetraCopy& copy, const UnknownLayout& layout, const Teuchos::ParameterList& parameters);
  void build_ifpack2(BelosPreconditioner kind, const TpetraCopy& copy);
  Eigen::ComputationInfo build_bond_factor(const TpetraCopy& copy, const SparseMatrix* P);

  RCP<op_t> m_preconditioner;
  RCP<MueLu::TpetraOperator<double, LO, GO, NT>> m_muelu;
  RCP<Ifpack2::Preconditioner<double, LO, GO, NT>> m_ifpack2;
  RCP<BlockFactor> m_block;
};

}  // namespace peristat::tpetra
