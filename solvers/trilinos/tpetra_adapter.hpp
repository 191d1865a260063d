// The Trilinos adapter's Tpetra side (solvers/trilinos/ only: Trilinos types stay below the
// seam): the distributed numbering of the unknowns, the Eigen matrix copied into a Tpetra
// CrsMatrix, and the tangent's action as a Tpetra operator. Compiled as C++17 with the rest
// of the adapter.
#pragma once

#include <vector>

#include <Teuchos_RCP.hpp>
#include <Tpetra_CrsMatrix.hpp>
#include <Tpetra_Import.hpp>
#include <Tpetra_Map.hpp>
#include <Tpetra_MultiVector.hpp>
#include <Tpetra_Operator.hpp>

#include "core/types.hpp"
#include "solvers/linear/linear_solver.hpp"

namespace peristat::tpetra {

using Teuchos::RCP;
using Teuchos::rcp;
using map_t = Tpetra::Map<>;
using LO = map_t::local_ordinal_type;
using GO = map_t::global_ordinal_type;
using NT = map_t::node_type;
using graph_t = Tpetra::CrsGraph<LO, GO, NT>;
using crs_t = Tpetra::CrsMatrix<double, LO, GO, NT>;
using row_t = Tpetra::RowMatrix<double, LO, GO, NT>;
using mv_t = Tpetra::MultiVector<double, LO, GO, NT>;
using op_t = Tpetra::Operator<double, LO, GO, NT>;
using import_t = Tpetra::Import<LO, GO, NT>;
using comm_t = Teuchos::Comm<int>;

/// The distributed numbering. With a layout, the unknowns of a particle are rows 2 q and
/// 2 q + 1 of the particle's node q (nodes: the particles that have an unknown, ordered by
/// their owner rank, then by particle); a prescribed direction of a node is a padding row
/// (diagonal only, zero right-hand side, zero solution). Ranks own contiguous ranges of
/// nodes: with the layout's owners, each rank's particles; without, strips of the lattice.
struct Distribution {
  int per_node = 1;
  std::vector<GO> row_of;               ///< per unknown: its global row
  GO n_rows = 0;                        ///< global rows, padding included
  GO first_row = 0;                     ///< this rank's first row
  std::vector<Index> unknown_of_local;  ///< per local row: its unknown, or -1 (padding)
  std::vector<Index> particle_of_local; ///< per local row: its particle (layout only)

  LO local_rows() const { return static_cast<LO>(unknown_of_local.size()); }
  bool owns(GO row) const { return row >= first_row && row < first_row + local_rows(); }
};

/// The numbering of n unknowns with `layout` on `rank` of `ranks`.
Distribution distribute(Index n, const UnknownLayout& layout, int rank, int ranks);

/// An Eigen matrix copied into a Tpetra CrsMatrix distributed by distribute(): the graph
/// once per pattern (analyze), the values at every factorisation (fill). A holds every row
/// (one process) or at least this rank's (a rank's own assembly, OwnedRows): each local row's
/// entries are read from A's columns; a padding row and a row without a stored diagonal get
/// one. Local indices from the start: the column map lists this rank's rows, then the other
/// ranks' rows that its rows touch, sorted. No global-index copy of the pattern is ever made
/// (at 700 x 700 it would be 2.4 GB).
class TpetraCopy {
 public:
  void analyze(const SparseMatrix& A, const UnknownLayout& layout, const RCP<const comm_t>& comm);
  /// A's values into the matrix's local storage (one memory space: Debian's Kokkos is Serial
  /// only), the matrix made again on the kept graph after release_values(). The padding rows'
  /// diagonal: the mean of A's diagonal over the local unknowns (a scale like the rest, so
  /// that neither the preconditioners nor the Krylov norms see a jump).
  void fill(const SparseMatrix& A);
  /// Drops the matrix (its values: 8 bytes per entry) until the next fill(); the graph stays.
  /// For a user that holds what it reads of the matrix in its own form (the threaded V-cycle's
  /// blocks) once nobody else holds the matrix.
  void release_values() { matrix = Teuchos::null; }
  /// analyze() was called.
  bool analyzed() const { return !m_graph.is_null(); }
  /// Translations in x and y and the in-plane rotation about the centroid, per local row.
  RCP<mv_t> rigid_body_modes(const UnknownLayout& layout) const;

  Distribution d;
  RCP<const map_t> map;
  RCP<crs_t> matrix;
  double padding = 1.0;  ///< the padding rows' diagonal of the last fill()

 private:
  void make_matrix();

  RCP<const graph_t> m_graph;
  std::vector<Index> m_remote_unknown;  ///< per column of another rank's row: its unknown, or -1
  std::vector<Index> m_diagonal;   ///< per local row: the position of its diagonal value
};

/// The tangent as a Tpetra operator (solver.belos.tangent: matrix_free): each apply imports
/// the entries of the vector that this rank's rows read (`reads`, unknowns: its ghosts two
/// horizons deep with its own rows), applies the problem's tangent action (on a rank of a
/// distributed run it computes that rank's rows only, QuasiStaticProblem::apply_tangent), and
/// keeps this rank's rows. A padding row is `padding` times its entry, as in the assembled copy.
class TangentOperator final : public op_t {
 public:
  TangentOperator(RCP<const map_t> map, std::vector<Index> reads, const Distribution& d, LinearSystem& system,
                  const double& padding);
  RCP<const map_t> getDomainMap() const override { return m_map; }
  RCP<const map_t> getRangeMap() const override { return m_map; }
  void apply(const mv_t& X, mv_t& Y, Teuchos::ETransp mode, double alpha, double beta) const override;

 private:
  RCP<const map_t> m_map;
  std::vector<Index> m_reads;
  RCP<import_t> m_import;
  RCP<mv_t> m_ghosts;
  const Distribution& m_d;
  LinearSystem& m_system;
  const double& m_padding;
  mutable VectorXd m_v, m_y;
};

}  // namespace peristat::tpetra
