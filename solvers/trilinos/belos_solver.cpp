#include "solvers/trilinos/belos_solver.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <omp.h>

#include <Eigen/CholmodSupport>

#include <BelosLinearProblem.hpp>
#include <BelosSolverFactory.hpp>
#include <BelosTpetraAdapter.hpp>
#include <Ifpack2_Factory.hpp>
#include <MueLu_CreateTpetraPreconditioner.hpp>
#include <Teuchos_DefaultMpiComm.hpp>
#include <Teuchos_XMLParameterListHelpers.hpp>
#include <Tpetra_Core.hpp>
#include <Tpetra_CrsMatrix.hpp>
#include <Tpetra_Import.hpp>
#include <Tpetra_Map.hpp>

#include "core/error.hpp"
#include "core/partition.hpp"
#include "solvers/linear/preconditioner_reuse.hpp"
#include "solvers/trilinos/parallel.hpp"
#include "solvers/trilinos/threaded_cycle.hpp"

namespace peristat {

namespace {

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

/// A rank's part (UnknownLayout::part()): the global rows come with the layout, two per node,
/// the rank's nodes being [first_node, first_node + its owned nodes).
Distribution distribute_part(Index n, const UnknownLayout& layout, int rank) {
  Distribution d;
  d.per_node = 2;
  d.row_of.resize(n);
  for (Index k = 0; k < n; ++k) {
    const Index p = layout.component[k] / 2;
    d.row_of[k] = 2 * GO(layout.global_node[static_cast<std::size_t>(p)]) + layout.component[k] % 2;
  }
  d.n_rows = 2 * GO(layout.global_nodes);
  d.first_row = 2 * GO(layout.first_node);
  std::vector<Index> owned_nodes;  // in global order: the part's order
  for (std::size_t p = 0; p < layout.global_node.size(); ++p)
    if (layout.owner[p] == rank && layout.global_node[p] >= 0) owned_nodes.push_back(static_cast<Index>(p));
  d.unknown_of_local.assign(2 * owned_nodes.size(), -1);
  d.particle_of_local.resize(2 * owned_nodes.size());
  for (std::size_t q = 0; q < owned_nodes.size(); ++q) {
    if (layout.global_node[static_cast<std::size_t>(owned_nodes[q])] != layout.first_node + GO(q))
      throw std::logic_error("distribute_part: a rank's nodes must be numbered in turn from its first");
    d.particle_of_local[2 * q] = d.particle_of_local[2 * q + 1] = owned_nodes[q];
  }
  for (Index k = 0; k < n; ++k)
    if (d.owns(d.row_of[k])) d.unknown_of_local[d.row_of[k] - d.first_row] = k;
  return d;
}

Distribution distribute(Index n, const UnknownLayout& layout, int rank, int ranks) {
  if (layout.part()) return distribute_part(n, layout, rank);
  Distribution d;
  d.row_of.resize(n);
  GO nodes = n;
  GO first_node = -1, end_node = -1;  // this rank's nodes; from the owners, or strips below
  std::vector<Index> particle_of_node;
  if (static_cast<Index>(layout.component.size()) == n && n > 0) {
    d.per_node = 2;
    const Index particles = *std::max_element(layout.component.begin(), layout.component.end()) / 2 + 1;
    std::vector<Index> node_of(particles, -1);
    for (Index k = 0; k < n; ++k) node_of[layout.component[k] / 2] = 0;
    const bool owners = ranks > 1 && !layout.owner.empty();
    const auto owner = [&](Index p) { return owners ? layout.owner[static_cast<std::size_t>(p)] : 0; };
    for (Index p = 0; p < particles; ++p)
      if (node_of[p] == 0) particle_of_node.push_back(p);
    // By owner, then by particle (stable: strips keep the particle order).
    std::stable_sort(particle_of_node.begin(), particle_of_node.end(),
                     [&](Index a, Index b) { return owner(a) < owner(b); });
    for (std::size_t q = 0; q < particle_of_node.size(); ++q)
      node_of[particle_of_node[q]] = static_cast<Index>(q);
    for (Index k = 0; k < n; ++k) d.row_of[k] = 2 * GO(node_of[layout.component[k] / 2]) + layout.component[k] % 2;
    nodes = static_cast<GO>(particle_of_node.size());
    if (owners) {
      const auto first = [&](int r) {
        return static_cast<GO>(std::lower_bound(particle_of_node.begin(), particle_of_node.end(), r,
                                                [&](Index p, int value) { return owner(p) < value; }) -
                               particle_of_node.begin());
      };
      first_node = first(rank);
      end_node = first(rank + 1);
    }
  } else {
    std::iota(d.row_of.begin(), d.row_of.end(), GO(0));
  }
  d.n_rows = d.per_node * nodes;
  if (first_node < 0) {
    first_node = strip_start(nodes, rank, ranks);
    end_node = strip_start(nodes, rank + 1, ranks);
  }
  d.first_row = d.per_node * first_node;
  d.unknown_of_local.assign(static_cast<std::size_t>(d.per_node * (end_node - first_node)), -1);
  for (Index k = 0; k < n; ++k)
    if (d.owns(d.row_of[k])) d.unknown_of_local[d.row_of[k] - d.first_row] = k;
  if (d.per_node == 2) {
    d.particle_of_local.resize(d.unknown_of_local.size());
    for (GO q = first_node; q < end_node; ++q)
      for (int c = 0; c < 2; ++c) d.particle_of_local[2 * (q - first_node) + c] = particle_of_node[q];
  }
  return d;
}

std::string first_line(const std::string& text) { return text.substr(0, text.find('\n')); }

/// An Eigen matrix copied into a Tpetra CrsMatrix distributed by distribute(): the graph
/// once per pattern (analyze), the values at every factorisation (fill). A holds every row
/// (one process) or at least this rank's (a rank's own assembly, OwnedRows): each local row's
/// entries are read from A's columns; a padding row and a row without a stored diagonal get
/// one. Local indices from the start: the column map lists this rank's rows, then the other
/// ranks' rows that its rows touch, sorted. No global-index copy of the pattern is ever made
/// (at 700 x 700 it would be 2.4 GB).
class TpetraCopy {
 public:
  void analyze(const SparseMatrix& A, const UnknownLayout& layout, const RCP<const Teuchos::Comm<int>>& comm) {
    if (!A.isCompressed()) throw std::logic_error("TpetraCopy::analyze: the matrix must be compressed");
    const Index n = static_cast<Index>(A.rows());
    d = distribute(n, layout, comm->getRank(), comm->getSize());
    const LO local = d.local_rows();
    map = rcp(new map_t(static_cast<Tpetra::global_size_t>(d.n_rows), static_cast<std::size_t>(local), GO(0), comm));
    // The unknowns of the local rows lie in [k_first, k_end), with other ranks' unknowns
    // between them when the owners are not strips (owns() is checked per entry). Each thread
    // reads every column of A for the entries in its share of that range, so that each local
    // row is one thread's.
    Index k_first = n, k_end = 0;
    for (LO r = 0; r < local; ++r)
      if (const Index k = d.unknown_of_local[r]; k >= 0) {
        k_first = std::min(k_first, k);
        k_end = std::max(k_end, k + 1);
      }
    const Index* outer = A.outerIndexPtr();
    const Index* inner = A.innerIndexPtr();
    const int threads = omp_get_max_threads();
    // The entries of column j in thread t's rows: `visit(k, position)` for each owned row k.
    const auto scan = [&](int t, int teams, Index j, auto visit) {
      const Index lo = k_first + static_cast<Index>((std::int64_t(k_end) - k_first) * t / teams);
      const Index hi = k_first + static_cast<Index>((std::int64_t(k_end) - k_first) * (t + 1) / teams);
      for (const Index* e = std::lower_bound(inner + outer[j], inner + outer[j + 1], lo);
           e != inner + outer[j + 1] && *e < hi; ++e)
        if (d.owns(d.row_of[*e])) visit(*e, static_cast<Index>(e - inner));
    };
    // Pass 1: entries per local row (the diagonal always), and the other ranks' rows touched.
    std::vector<std::size_t> count(static_cast<std::size_t>(local), 1);
    std::vector<std::vector<GO>> remote_of(static_cast<std::size_t>(threads));
#pragma omp parallel num_threads(threads)
    {
      const int t = omp_get_thread_num(), teams = omp_get_num_threads();
      for (Index j = 0; j < n; ++j) {
        const bool other_rank = !d.owns(d.row_of[j]);
        bool touched = false;
        scan(t, teams, j, [&](Index k, Index) {
          if (k != j) ++count[d.row_of[k] - d.first_row];
          touched = true;
        });
        if (other_rank && touched) remote_of[t].push_back(d.row_of[j]);
      }
    }
    std::vector<GO> remote;
    for (const std::vector<GO>& r : remote_of) remote.insert(remote.end(), r.begin(), r.end());
    std::sort(remote.begin(), remote.end());
    remote.erase(std::unique(remote.begin(), remote.end()), remote.end());
    auto local_column = [&](GO column) -> LO {
      if (d.owns(column)) return static_cast<LO>(column - d.first_row);
      return local + static_cast<LO>(std::lower_bound(remote.begin(), remote.end(), column) - remote.begin());
    };
    std::vector<GO> columns_of_map(static_cast<std::size_t>(local) + remote.size());
    std::iota(columns_of_map.begin(), columns_of_map.begin() + local, d.first_row);
    std::copy(remote.begin(), remote.end(), columns_of_map.begin() + local);
    const RCP<const map_t> col_map = rcp(new map_t(Teuchos::OrdinalTraits<Tpetra::global_size_t>::invalid(),
                                                   Teuchos::ArrayView<const GO>(columns_of_map), GO(0), comm));
    Teuchos::ArrayRCP<std::size_t> row_pointers = Teuchos::arcp<std::size_t>(local + 1);
    row_pointers[0] = 0;
    for (LO r = 0; r < local; ++r) row_pointers[r + 1] = row_pointers[r] + count[r];
    const std::size_t nonzeros = row_pointers[local];
    Teuchos::ArrayRCP<LO> column_indices = Teuchos::arcp<LO>(static_cast<Teuchos_Ordinal>(nonzeros));
    m_source.assign(nonzeros, -1);
    m_diagonal.resize(local);
    // Pass 2: each row's diagonal first (stored in A or not), then its other entries in the
    // order of A's columns.
    std::vector<std::size_t>& next = count;
    for (LO r = 0; r < local; ++r) {
      column_indices[row_pointers[r]] = r;
      next[r] = row_pointers[r] + 1;
    }
#pragma omp parallel num_threads(threads)
    {
      const int t = omp_get_thread_num(), teams = omp_get_num_threads();
      for (Index j = 0; j < n; ++j) {
        const LO column = local_column(d.row_of[j]);
        scan(t, teams, j, [&](Index k, Index at) {
          const LO r = static_cast<LO>(d.row_of[k] - d.first_row);
          const std::size_t slot = k == j ? row_pointers[r] : next[r]++;
          column_indices[slot] = column;
          m_source[slot] = at;
        });
      }
    }
    // Pass 3: each row sorted by local column (Tpetra wants them so).
#pragma omp parallel
    {
      std::vector<std::pair<LO, Index>> row;
#pragma omp for schedule(static)
      for (LO r = 0; r < local; ++r) {
        row.clear();
        for (std::size_t e = row_pointers[r]; e < row_pointers[r + 1]; ++e)
          row.emplace_back(column_indices[e], m_source[e]);
        std::sort(row.begin(), row.end());
        for (std::size_t e = 0; e < row.size(); ++e) {
          column_indices[row_pointers[r] + e] = row[e].first;
          m_source[row_pointers[r] + e] = row[e].second;
          if (row[e].first == r) m_diagonal[r] = static_cast<Index>(row_pointers[r] + e);
        }
      }
    }
    m_row_start.assign(row_pointers.begin(), row_pointers.end());
    RCP<graph_t> graph = rcp(new graph_t(map, col_map, row_pointers, column_indices));
    graph->expertStaticFillComplete(map, map);
    matrix = rcp(new crs_t(graph));
    matrix->fillComplete(map, map);
  }

  /// A's values into the matrix's local storage (one memory space: Debian's Kokkos is Serial
  /// only). The padding rows' diagonal: the mean of A's diagonal over the local unknowns (a
  /// scale like the rest, so that neither the preconditioners nor the Krylov norms see a jump).
  void fill(const SparseMatrix& A) {
    const auto values = matrix->getLocalMatrixHost().values;
    const double* a = A.valuePtr();
    const LO local = d.local_rows();
    double diagonal_sum = 0.0;
    Index diagonals = 0;
    for (LO r = 0; r < local; ++r) {
      for (Index e = m_row_start[r]; e < m_row_start[r + 1]; ++e) values(e) = m_source[e] >= 0 ? a[m_source[e]] : 0.0;
      if (d.unknown_of_local[r] >= 0) {
        diagonal_sum += std::abs(values(m_diagonal[r]));
        ++diagonals;
      }
    }
    padding = diagonals > 0 && diagonal_sum > 0.0 ? diagonal_sum / diagonals : 1.0;
    for (LO r = 0; r < local; ++r)
      if (d.unknown_of_local[r] < 0) values(m_diagonal[r]) = padding;
  }

  /// Translations in x and y and the in-plane rotation about the centroid, per local row.
  RCP<mv_t> rigid_body_modes(const UnknownLayout& layout) const {
    RCP<mv_t> modes = rcp(new mv_t(map, 3));
    double cx = 0.0, cy = 0.0;
    for (std::size_t i = 0; i < layout.x.size(); ++i) {
      cx += layout.x[i];
      cy += layout.y[i];
    }
    cx /= std::max<std::size_t>(layout.x.size(), 1);
    cy /= std::max<std::size_t>(layout.y.size(), 1);
    if (std::isfinite(layout.centre_x) && std::isfinite(layout.centre_y)) {
      cx = layout.centre_x;
      cy = layout.centre_y;
    }
    for (LO r = 0; r < d.local_rows(); ++r) {
      const Index p = d.particle_of_local[r];
      const int dir = static_cast<int>((d.first_row + r) % 2);
      modes->replaceLocalValue(r, 0, dir == 0 ? 1.0 : 0.0);
      modes->replaceLocalValue(r, 1, dir == 1 ? 1.0 : 0.0);
      modes->replaceLocalValue(r, 2, dir == 0 ? -(layout.y[p] - cy) : layout.x[p] - cx);
    }
    return modes;
  }

  Distribution d;
  RCP<const map_t> map;
  RCP<crs_t> matrix;
  double padding = 1.0;  ///< the padding rows' diagonal of the last fill()

 private:
  std::vector<Index> m_row_start;  ///< Tpetra's local row offsets
  std::vector<Index> m_source;     ///< per local value: its position in A's values, or -1
  std::vector<Index> m_diagonal;   ///< per local row: the position of its diagonal value
};

/// Additive Schwarz with a CHOLMOD factor of each rank's diagonal block of the bond matrix
/// (the `cg` path's preconditioner, on one rank exactly that factor).
class BlockFactor final : public op_t {
 public:
  explicit BlockFactor(RCP<const map_t> map) : m_map(std::move(map)) {
    m_factor.cholmod().print = 0;  // failures reach the user through info()
  }

  /// Factorises this rank's block of P (P's rows and columns in the unknowns' numbering);
  /// padding rows get `padding` on the diagonal. False when the block is not positive definite.
  bool factorize(const SparseMatrix& P, const Distribution& d, double padding) {
    const LO n = d.local_rows();
    m_triplets.clear();
    for (LO r = 0; r < n; ++r) {
      const Index k = d.unknown_of_local[r];
      if (k < 0) {
        m_triplets.emplace_back(r, r, padding);
        continue;
      }
      for (SparseMatrix::InnerIterator it(P, k); it; ++it) {
        const GO row = d.row_of[it.row()];
        if (d.owns(row)) m_triplets.emplace_back(static_cast<Index>(row - d.first_row), r, it.value());
      }
    }
    m_block.resize(n, n);
    m_block.setFromTriplets(m_triplets.begin(), m_triplets.end());
    if (m_pattern_nonzeros != m_block.nonZeros()) {
      m_factor.analyzePattern(m_block);
      m_pattern_nonzeros = m_block.nonZeros();
    }
    m_factor.factorize(m_block);
    m_in.resize(n);
    m_out.resize(n);
    return m_factor.info() == Eigen::Success;
  }

  RCP<const map_t> getDomainMap() const override { return m_map; }
  RCP<const map_t> getRangeMap() const override { return m_map; }
  void apply(const mv_t& X, mv_t& Y, Teuchos::ETransp /*mode*/, double alpha, double beta) const override {
    for (std::size_t v = 0; v < X.getNumVectors(); ++v) {
      const Teuchos::ArrayRCP<const double> x = X.getData(v);
      const Teuchos::ArrayRCP<double> y = Y.getDataNonConst(v);
      for (Index i = 0; i < m_in.size(); ++i) m_in[i] = x[i];
      m_out = m_factor.solve(m_in);
      for (Index i = 0; i < m_out.size(); ++i) y[i] = beta == 0.0 ? alpha * m_out[i] : alpha * m_out[i] + beta * y[i];
    }
  }

 private:
  RCP<const map_t> m_map;
  std::vector<Eigen::Triplet<double, Index>> m_triplets;
  SparseMatrix m_block;
  Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower> m_factor;
  Index m_pattern_nonzeros = -1;
  mutable VectorXd m_in, m_out;
};

/// The tangent as a Tpetra operator (solver.belos.tangent: matrix_free): each apply imports
/// the entries of the vector that this rank's rows read (`reads`, unknowns: its ghosts two
/// horizons deep with its own rows; every unknown when not given), applies the problem's
/// tangent action (on a rank of a distributed run it computes that rank's rows only,
/// QuasiStaticProblem::apply_tangent), and keeps this rank's rows. A padding row is `padding`
/// times its entry, as in the assembled copy.
class TangentOperator final : public op_t {
 public:
  TangentOperator(RCP<const map_t> map, std::vector<Index> reads, const Distribution& d,
                  LinearSolver::Operator apply, const double& padding)
      : m_map(std::move(map)),
        m_reads(std::move(reads)),
        m_d(d),
        m_apply(std::move(apply)),
        m_padding(padding),
        m_v(VectorXd::Zero(static_cast<Index>(d.row_of.size()))),
        m_y(static_cast<Index>(d.row_of.size())) {
    std::vector<GO> rows(m_reads.size());
    for (std::size_t k = 0; k < m_reads.size(); ++k) rows[k] = m_d.row_of[m_reads[k]];
    const RCP<const map_t> ghosts =
        rcp(new map_t(Teuchos::OrdinalTraits<Tpetra::global_size_t>::invalid(),
                      Teuchos::ArrayView<const GO>(rows), GO(0), m_map->getComm()));
    m_import = rcp(new import_t(m_map, ghosts));
    m_ghosts = rcp(new mv_t(ghosts, 1));
  }
  RCP<const map_t> getDomainMap() const override { return m_map; }
  RCP<const map_t> getRangeMap() const override { return m_map; }
  void apply(const mv_t& X, mv_t& Y, Teuchos::ETransp /*mode*/, double alpha, double beta) const override {
    const LO local = m_d.local_rows();
    for (std::size_t c = 0; c < X.getNumVectors(); ++c) {
      m_ghosts->getVectorNonConst(0)->doImport(*X.getVector(c), *m_import, Tpetra::INSERT);
      {
        const Teuchos::ArrayRCP<const double> ghosts = m_ghosts->getData(0);
        for (std::size_t k = 0; k < m_reads.size(); ++k) m_v[m_reads[k]] = ghosts[static_cast<LO>(k)];
      }
      m_apply(m_v, m_y);
      const Teuchos::ArrayRCP<const double> x = X.getData(c);
      const Teuchos::ArrayRCP<double> y = Y.getDataNonConst(c);
      for (LO r = 0; r < local; ++r) {
        const Index k = m_d.unknown_of_local[r];
        const double ax = alpha * (k >= 0 ? m_y[k] : m_padding * x[r]);
        y[r] = beta == 0.0 ? ax : ax + beta * y[r];
      }
    }
  }

 private:
  RCP<const map_t> m_map;
  std::vector<Index> m_reads;
  RCP<import_t> m_import;
  RCP<mv_t> m_ghosts;
  const Distribution& m_d;
  LinearSolver::Operator m_apply;
  const double& m_padding;
  mutable VectorXd m_v, m_y;
};

/// One V-cycle of MueLu's smoothed aggregation on a matrix P, as the preconditioner "solve"
/// of factor-preconditioned Krylov (solver.krylov.preconditioner: bond_amg): the bond matrix
/// approximated instead of factorised. In this process only (a serial communicator), the
/// unknowns grouped by particle with the rigid-body modes as near-null space. A fixed linear
/// operator, symmetric positive definite for a symmetric positive definite P (Chebyshev
/// smoothing, the same before and after, and a relaxed coarsest level), so CG may use it.
class MueLuCycle final : public LinearSolver {
 public:
  explicit MueLuCycle(CycleApply apply) : m_apply(apply) {
    parallel::ensure_started();
    // This process's own communicator: under mpirun every rank runs the same Krylov iteration
    // on its whole copy of the model (matrix_free is not distributed). Teuchos's SerialComm
    // crashes MueLu 13.2's hierarchy set-up; an MPI communicator of one process does not.
    m_comm = rcp(new Teuchos::MpiComm<int>(Teuchos::opaqueWrapper(MPI_COMM_SELF)));
  }

  void analyzePattern(const SparseMatrix& P) override {
    m_info = Eigen::Success;
    m_copy.analyze(P, m_layout, m_comm);
    m_in = rcp(new mv_t(m_copy.map, 1));
    m_out = rcp(new mv_t(m_copy.map, 1));
    release_factor();
  }

  void factorize(const SparseMatrix& P) override {
    m_info = Eigen::Success;
    if (m_copy.matrix.is_null()) analyzePattern(P);
    m_copy.fill(P);
    set_up();
  }

  void release_factor() override {
    m_cycle.reset();
    m_muelu = Teuchos::null;
  }

  /// P's values into the hierarchy's matrix, then P freed: the set-up, the peak of a
  /// million-particle run, never holds both. The set-up itself waits for set_up_loaded().
  void load(SparseMatrix& P) override {
    m_info = Eigen::Success;
    release_factor();
    if (m_copy.matrix.is_null()) analyzePattern(P);
    m_copy.fill(P);
    P = SparseMatrix();
    m_loaded = true;
  }
  void set_up_loaded() override {
    if (m_loaded) set_up();
  }

  void solve(const VectorXd& b, VectorXd& x) override {
    set_up_loaded();
    if (m_muelu.is_null()) {  // no hierarchy (a failed set-up): the caller sees info()
      m_info = Eigen::NumericalIssue;
      return;
    }
    const Distribution& d = m_copy.d;
    const LO local = d.local_rows();
    {
      const Teuchos::ArrayRCP<double> in = m_in->getDataNonConst(0);
      for (LO r = 0; r < local; ++r) in[r] = d.unknown_of_local[r] >= 0 ? b[d.unknown_of_local[r]] : 0.0;
    }
    if (m_cycle)
      m_cycle->apply(m_in->getData(0).getRawPtr(), m_out->getDataNonConst(0).getRawPtr());
    else
      m_muelu->apply(*m_in, *m_out);
    x.resize(b.size());
    const Teuchos::ArrayRCP<const double> out = m_out->getData(0);
    for (LO r = 0; r < local; ++r)
      if (d.unknown_of_local[r] >= 0) x[d.unknown_of_local[r]] = out[r];
  }

  Eigen::ComputationInfo info() const override { return m_info; }
  /// "muelu", or "muelu-serial" when MueLu applies the cycle on one core (not threaded, or a
  /// hierarchy the threaded cycle does not repeat).
  std::string name() const override { return m_muelu.is_null() || m_cycle ? "muelu" : "muelu-serial"; }
  bool needs_symmetric() const override { return true; }
  /// The run's tangents may be unsymmetric: the cycle will serve GMRES (smoothing degree 2).
  void set_may_be_unsymmetric(bool may) override { m_gmres = may; }
  long factorizations() const override { return m_builds; }
  bool needs_unknown_layout() const override { return true; }
  void set_unknown_layout(const UnknownLayout& layout) override { m_layout = layout; }

 private:
  /// MueLu's hierarchy of the filled copy, and its threaded cycle.
  void set_up() {
    m_loaded = false;
    ++m_builds;
    try {
      // The old hierarchy goes before the new one is built: at a million particles the two
      // together were the run's peak (9.1 against 8.1 GB). Rebuilding in place ("reuse: type"
      // RP with ReuseTpetraPreconditioner) saved set-up time at 300 x 300 but held 0.3 GB more
      // and threw at 1000 x 1000.
      release_factor();
      Teuchos::ParameterList p;
      p.set("verbosity", "none");
      // As belos's muelu (its measurements): Chebyshev smoothing, a relaxed coarsest level.
      p.set("smoother: type", "CHEBYSHEV");
      // Chebyshev degree 2 where the tangents may be unsymmetric (frictional contact: the
      // cycle serves GMRES while pairs slip), 1 otherwise (CG). Measured at paper resolution
      // (docs/performance.md, "Fifth round"), degree 2 against 1: Krylov iterations 4.1
      // 301 -> 206 (wall 3.33 -> 3.01 s, medians of 6), 4.4 2690 -> 2244, 4.2 3.2 -> 2.6 s,
      // 4.3 the same wall; but the symmetric ones take more: the frictionless LEFM case
      // 150 -> 165 (5.1 -> 6.0 s), the tension plate 400 x 400 218 -> 239. The smoother is
      // symmetric either way, so CG may use a degree-2 cycle while all pairs stick.
      p.sublist("smoother: params").set("chebyshev: degree", m_gmres ? 2 : 1);
      p.set("coarse: type", "RELAXATION");
      p.set("coarse: max size", 100);
      // R = P^T applied, not stored: 20 MB of 862 MB at 300 x 300, the same iterations.
      p.set("transpose: use implicit", true);
      // Aggregates ignore couplings weaker than 0.02 of their rows' diagonals (the contact
      // pairs' blocks mostly): at paper resolution 4.2 2.75 -> 1.55 s (Krylov 782 -> 432), 4.1
      // 4.22 -> 3.86 s, 4.3 1.00 -> 0.83 s; the tension plate unchanged (300 x 300 and
      // 1000 x 1000: the same time, memory and iterations). 0.01 and 0.03-0.05 gain less,
      // 0.1 costs 4-8 times the iterations.
      p.set("aggregation: drop tol", 0.02);
      // ... but the prolongator is smoothed with the whole matrix, not a filtered copy: one
      // matrix fewer to build. Case 4.3 at paper resolution: Krylov 221 -> 241 with one set-up
      // fewer (0.24 -> 0.14 s of set-up); tension 300 x 300, one step: set-up 2.0 -> 1.5 s; the
      // LEFM case 169 -> 150 Krylov; 4.1, 4.2 and 4.4 within 2 iterations.
      p.set("sa: use filtered matrix", false);
      // Above kAmgMemoryFirstRows the Galerkin product P^T A P is formed without the temporary
      // A P, which made the set-up the run's peak: 1000 x 1000, peak 7.97 -> 7.54 GB (1e9 B)
      // before the eighth round; 700 x 700, 3.96 -> 3.77 GB for 8.5 -> 10.3 s of set-up.
      // Below, time counts more.
      p.set("rap: triple product", m_copy.d.n_rows > kAmgMemoryFirstRows);
      if (m_copy.d.per_node == 2) {
        p.set("number of equations", 2);
        p.sublist("user data").set("Nullspace", m_copy.rigid_body_modes(m_layout));
      }
      m_muelu = MueLu::CreateTpetraPreconditioner(RCP<op_t>(m_copy.matrix), p);
      // The cycle on this program's threads (MueLu's apply runs on one core: Debian's Kokkos
      // is Serial only); a hierarchy it cannot repeat is applied by MueLu, and said so in name().
      // Its finest level in 2 x 2 blocks too, where memory allows (up to kAmgMemoryFirstRows), of
      // floats by default (ThreadedCycle::Blocks).
      if (m_apply != CycleApply::muelu) {
        using Finest = ThreadedCycle::Finest;
        const bool blocked = m_copy.d.per_node == 2 && m_copy.d.n_rows <= kAmgMemoryFirstRows;
        const Finest finest =
            !blocked ? Finest::csr : m_apply == CycleApply::threads ? Finest::float_blocks : Finest::blocks;
        m_cycle = ThreadedCycle::from(*m_muelu->GetHierarchy(), m_why_not, finest);
      }
    } catch (const std::exception&) {  // a Trilinos failure (e.g. a zero pivot): the seam's terms
      release_factor();
      m_info = Eigen::NumericalIssue;
    }
  }

  RCP<const Teuchos::Comm<int>> m_comm;
  UnknownLayout m_layout;
  TpetraCopy m_copy;
  RCP<mv_t> m_in, m_out;
  RCP<MueLu::TpetraOperator<double, LO, GO, NT>> m_muelu;
  CycleApply m_apply;
  bool m_loaded = false;  ///< load() filled m_copy for a set-up not built yet
  bool m_gmres = false;   ///< the cycle may serve GMRES (set_may_be_unsymmetric): Chebyshev degree 2
  std::unique_ptr<ThreadedCycle> m_cycle;  ///< m_muelu's cycle on this program's threads, or null
  std::string m_why_not;                   ///< why the last hierarchy has no threaded cycle
  long m_builds = 0;
  Eigen::ComputationInfo m_info = Eigen::Success;
};

class BelosSolver final : public LinearSolver {
 public:
  explicit BelosSolver(const BelosOptions& o) : m_options(o) {
    parallel::ensure_started();
    m_comm = Tpetra::getDefaultComm();
    if (!o.muelu_parameters.empty()) {
      try {
        Teuchos::updateParametersFromXmlFile(o.muelu_parameters, Teuchos::inOutArg(m_muelu_parameters));
      } catch (const std::exception& e) {
        throw InputError("solver.belos.muelu_parameters: \"" + o.muelu_parameters +
                         "\" is not a Teuchos XML parameter list: " + first_line(e.what()));
      }
    }
  }

  void analyzePattern(const SparseMatrix& A) override {
    m_info = Eigen::Success;
    if (matrix_free() && m_P == nullptr) {  // the copy is the bond matrix's: it comes first
      m_info = Eigen::InvalidInput;
      return;
    }
    m_copy.analyze(matrix_free() ? *m_P : A, m_layout, m_comm);
    if (!m_layout.part()) {  // the whole solution on every rank after each solve
      m_replicated = rcp(new map_t(static_cast<Tpetra::global_size_t>(m_copy.d.n_rows), GO(0), m_comm,
                                   Tpetra::LocallyReplicated));
      m_import = rcp(new import_t(m_copy.map, m_replicated));
      m_X_all = rcp(new mv_t(m_replicated, 1));
    }
    m_X = rcp(new mv_t(m_copy.map, 1));
    m_B = rcp(new mv_t(m_copy.map, 1));
    m_problem = rcp(new Belos::LinearProblem<double, mv_t, op_t>());
    if (matrix_free()) {
      std::vector<Index> reads;
      if (m_reads) {
        reads = m_reads();
      } else {
        reads.resize(m_copy.d.row_of.size());
        std::iota(reads.begin(), reads.end(), Index(0));
      }
      m_tangent = rcp(new TangentOperator(m_copy.map, std::move(reads), m_copy.d, m_apply, m_copy.padding));
    }
    m_preconditioner = Teuchos::null;
    m_muelu = Teuchos::null;
    m_ifpack2 = Teuchos::null;
    m_block = Teuchos::null;
    m_reuse.renew();
  }

  void factorize(const SparseMatrix& A) override {
    m_info = Eigen::Success;
    if (m_copy.matrix.is_null()) analyzePattern(A);
    if (m_info != Eigen::Success) return;
    m_copy.fill(matrix_free() ? *m_P : A);
    if (m_reuse.due()) build_preconditioner();
  }

  void solve(const VectorXd& b, VectorXd& x) override {
    const Index n = static_cast<Index>(b.size());
    if (x.size() != n) x = VectorXd::Zero(n);
    m_iterations = 0;
    m_error = 0.0;
    if (rhs_is_zero(b)) {
      x.setZero();
      m_info = Eigen::Success;
      return;
    }
    m_reuse.solve(
        !m_preconditioner.is_null(), [&] { build_preconditioner(); }, [&] { run(b, x); }, m_info,
        m_iterations, m_error);
  }

  Eigen::ComputationInfo info() const override { return m_info; }
  std::string name() const override {
    return "belos-" + std::string(to_string(m_options.method)) + "+" +
           std::string(to_string(m_options.preconditioner)) + (matrix_free() ? "+matrix_free" : "");
  }
  bool needs_symmetric() const override { return m_options.method == BelosMethod::cg; }
  bool iterative() const override { return true; }
  void set_relative_tolerance(double rtol) override { m_rtol = std::max(rtol, m_options.rtol); }
  int iterations() const override { return m_iterations; }
  double error() const override { return m_error; }
  long factorizations() const override { return m_builds; }
  /// The bond matrix: the bond factor's, and with a matrix-free tangent every preconditioner's.
  bool uses_preconditioner_matrix() const override {
    return m_options.preconditioner == BelosPreconditioner::bond_factor || matrix_free();
  }
  bool needs_operator() const override { return matrix_free(); }
  void set_operator(Operator apply) override { m_apply = std::move(apply); }
  void set_operator_reads(OperatorReads reads) override { m_reads = std::move(reads); }
  void set_preconditioner_matrix(const SparseMatrix& P) override { m_P = &P; }
  void set_symmetric(bool symmetric) override { m_symmetric = symmetric; }
  void renew_preconditioner() override { m_reuse.renew(); }
  void set_state(std::uint64_t state) override { m_reuse.set_state(state); }
  bool needs_unknown_layout() const override { return true; }
  void set_unknown_layout(const UnknownLayout& layout) override { m_layout = layout; }

 private:
  bool matrix_free() const { return m_options.tangent == BelosTangent::matrix_free; }

  /// Whether b is zero on every rank: on a part, over every rank's own rows (collective), so
  /// that no rank returns while the others solve.
  bool rhs_is_zero(const VectorXd& b) const {
    if (!m_layout.part()) return b.norm() == 0.0;
    double owned = 0.0;
    for (const Index k : m_copy.d.unknown_of_local)
      if (k >= 0) owned = std::max(owned, std::abs(b[k]));
    return parallel::max_over_ranks(owned) == 0.0;
  }

  void build_preconditioner() {
    m_reuse.built();
    m_info = Eigen::Success;
    // Until the new one is built. The old hierarchy goes first, from the Belos problem too: the
    // set-up would otherwise hold two (700 x 700 on four ranks: 0.14 GB of the 1.52 GB peak).
    m_preconditioner = Teuchos::null;
    m_muelu = Teuchos::null;
    if (!m_problem.is_null()) m_problem->setRightPrec(Teuchos::null);
    ++m_builds;
    try {
      switch (m_options.preconditioner) {
        case BelosPreconditioner::muelu: {
          Teuchos::ParameterList p;
          p.set("verbosity", "none");
          // Amesos2's KLU2 gives wrong answers on two or more ranks (DEPENDENCIES.md): the
          // coarsest level is smoothed instead of solved.
          p.set("coarse: type", "RELAXATION");
          // Measured on the tension plate (100 x 100, docs/guide/distributed.md): Chebyshev
          // smoothing costs a third of MueLu's default symmetric Gauss-Seidel on these wide
          // rows (about 300 entries), and a coarsest level of at most 100 rows keeps the
          // relaxed coarse solve from limiting convergence (37 iterations per solve against 62).
          p.set("smoother: type", "CHEBYSHEV");
          p.set("coarse: max size", 100);
          p.setParameters(m_muelu_parameters);  // the user's list wins
          if (m_copy.d.per_node == 2) {
            p.set("number of equations", 2);
            p.sublist("user data").set("Nullspace", m_copy.rigid_body_modes(m_layout));
          }
          m_muelu = MueLu::CreateTpetraPreconditioner(RCP<op_t>(m_copy.matrix), p);
          m_preconditioner = m_muelu;
          break;
        }
        case BelosPreconditioner::ifpack2_ilut:
        case BelosPreconditioner::ifpack2_relaxation: {
          if (m_ifpack2.is_null()) {
            m_ifpack2 = Ifpack2::Factory::create<row_t>("SCHWARZ", RCP<const row_t>(m_copy.matrix));
            Teuchos::ParameterList p;
            p.set("schwarz: overlap level", 0);
            if (m_options.preconditioner == BelosPreconditioner::ifpack2_ilut) {
              p.set("schwarz: inner preconditioner name", "ILUT");
              p.sublist("schwarz: inner preconditioner parameters").set("fact: ilut level-of-fill", 2.0);
              p.sublist("schwarz: inner preconditioner parameters").set("fact: drop tolerance", 0.0);
            } else {
              p.set("schwarz: inner preconditioner name", "RELAXATION");
              p.sublist("schwarz: inner preconditioner parameters").set("relaxation: type", "Symmetric Gauss-Seidel");
              p.sublist("schwarz: inner preconditioner parameters").set("relaxation: sweeps", 2);
            }
            m_ifpack2->setParameters(p);
            m_ifpack2->initialize();
          }
          m_ifpack2->compute();
          m_preconditioner = m_ifpack2;
          break;
        }
        case BelosPreconditioner::bond_factor: {
          if (m_P == nullptr || m_P->rows() != static_cast<Index>(m_copy.d.row_of.size())) {
            m_info = Eigen::InvalidInput;
            return;
          }
          if (m_block.is_null()) m_block = rcp(new BlockFactor(m_copy.map));
          if (!m_block->factorize(*m_P, m_copy.d, m_copy.padding)) {
            m_info = Eigen::NumericalIssue;
            return;
          }
          m_preconditioner = m_block;
          break;
        }
      }
    } catch (const std::exception&) {  // a Trilinos failure (e.g. a zero pivot): the seam's terms
      m_info = Eigen::NumericalIssue;
      m_preconditioner = Teuchos::null;
    }
  }

  void run(const VectorXd& b, VectorXd& x) {
    const Distribution& d = m_copy.d;
    const LO local = d.local_rows();
    {
      const Teuchos::ArrayRCP<double> bl = m_B->getDataNonConst(0), xl = m_X->getDataNonConst(0);
      for (LO r = 0; r < local; ++r) {
        const Index k = d.unknown_of_local[r];
        bl[r] = k >= 0 ? b[k] : 0.0;
        xl[r] = k >= 0 ? x[k] : 0.0;
      }
    }
    const bool cg = m_options.method == BelosMethod::cg || (m_options.method == BelosMethod::automatic && m_symmetric);
    RCP<Belos::SolverManager<double, mv_t, op_t>>& solver = cg ? m_cg : m_gmres;
    double& applied = cg ? m_cg_rtol : m_gmres_rtol;  // the tolerance the solver holds
    try {
      if (!solver.is_null() && applied != m_rtol) {  // a new forcing term (Newton's)
        RCP<Teuchos::ParameterList> p = rcp(new Teuchos::ParameterList(*solver->getCurrentParameters()));
        p->set("Convergence Tolerance", m_rtol);
        solver->setParameters(p);
        applied = m_rtol;
      }
      if (solver.is_null()) {
        RCP<Teuchos::ParameterList> p = rcp(new Teuchos::ParameterList);
        p->set("Convergence Tolerance", m_rtol);
        applied = m_rtol;
        p->set("Maximum Iterations", m_options.max_iterations);
        if (cg) {
          p->set("Assert Positive Definiteness", false);  // a breakdown is reported, not thrown
          p->set("Residual Scaling", "Norm of RHS");
        } else {
          p->set("Num Blocks", m_options.restart);
          p->set("Maximum Restarts", m_options.max_iterations / m_options.restart + 1);
          p->set("Implicit Residual Scaling", "Norm of RHS");
          p->set("Explicit Residual Scaling", "Norm of RHS");
        }
        Belos::SolverFactory<double, mv_t, op_t> factory;
        solver = factory.create(cg ? "CG" : "GMRES", p);
      }
      m_problem->setOperator(matrix_free() ? RCP<op_t>(m_tangent) : RCP<op_t>(m_copy.matrix));
      m_problem->setRightPrec(m_preconditioner);
      m_problem->setProblem(m_X, m_B);
      solver->setProblem(m_problem);
      const Belos::ReturnType result = solver->solve();
      m_iterations = solver->getNumIters();
      m_error = solver->achievedTol();
      m_info = result == Belos::Converged ? Eigen::Success : Eigen::NoConvergence;
    } catch (const std::exception&) {
      m_info = Eigen::NumericalIssue;
      return;
    }
    if (m_layout.part()) {  // a rank's part: its own unknowns; the caller imports its ghosts
      const Teuchos::ArrayRCP<const double> own = m_X->getData(0);
      for (LO r = 0; r < local; ++r)
        if (d.unknown_of_local[r] >= 0) x[d.unknown_of_local[r]] = own[r];
      return;
    }
    // Every rank gets the whole solution: the model above the seam is the same on all ranks.
    m_X_all->doImport(*m_X, *m_import, Tpetra::INSERT);
    const Teuchos::ArrayRCP<const double> all = m_X_all->getData(0);
    for (Index k = 0; k < static_cast<Index>(x.size()); ++k) x[k] = all[d.row_of[k]];
  }

  BelosOptions m_options;
  Teuchos::ParameterList m_muelu_parameters;  ///< solver.belos.muelu_parameters, or empty
  RCP<const Teuchos::Comm<int>> m_comm;
  UnknownLayout m_layout;
  TpetraCopy m_copy;  ///< of the tangent, or with a matrix-free tangent of the bond matrix
  Operator m_apply;   ///< the tangent's action (matrix-free)
  OperatorReads m_reads;  ///< the entries of v it reads for this rank's rows (every entry if unset)
  RCP<TangentOperator> m_tangent;
  RCP<const map_t> m_replicated;
  RCP<import_t> m_import;
  RCP<mv_t> m_X, m_B, m_X_all;
  RCP<Belos::LinearProblem<double, mv_t, op_t>> m_problem;
  RCP<Belos::SolverManager<double, mv_t, op_t>> m_cg, m_gmres;
  RCP<op_t> m_preconditioner;
  RCP<MueLu::TpetraOperator<double, LO, GO, NT>> m_muelu;
  RCP<Ifpack2::Preconditioner<double, LO, GO, NT>> m_ifpack2;
  RCP<BlockFactor> m_block;
  const SparseMatrix* m_P = nullptr;
  bool m_symmetric = true;
  /// The relative residual of the next solves (solver.belos.rtol, or Newton's looser forcing
  /// term), and the one the CG and GMRES solver managers were last given.
  double m_rtol = m_options.rtol, m_cg_rtol = -1.0, m_gmres_rtol = -1.0;
  PreconditionerReuse m_reuse;
  int m_iterations = 0;
  double m_error = 0.0;
  long m_builds = 0;
  Eigen::ComputationInfo m_info = Eigen::Success;
};

}  // namespace

std::unique_ptr<LinearSolver> make_belos_solver(const BelosOptions& options) {
  return std::make_unique<BelosSolver>(options);
}

std::unique_ptr<LinearSolver> make_muelu_cycle(CycleApply apply) { return std::make_unique<MueLuCycle>(apply); }

}  // namespace peristat
