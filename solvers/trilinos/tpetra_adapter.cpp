#include "solvers/trilinos/tpetra_adapter.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <utility>

#include <omp.h>


namespace peristat::tpetra {

namespace {

using RowPointers = Kokkos::View<std::size_t*, NT::device_type>;
using ColumnIndices = Kokkos::View<LO*, NT::device_type>;

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

/// The entries of column j of A in thread t's share of the rows [k_first, k_end) that this
/// rank owns: `visit(k, position)` for each (each local row is one thread's).
struct ColumnScan {
  const Distribution& d;
  const Index* outer;
  const Index* inner;
  Index k_first, k_end;

  template <class Visit>
  void operator()(int t, int teams, Index j, Visit visit) const {
    const Index lo = k_first + static_cast<Index>((std::int64_t(k_end) - k_first) * t / teams);
    const Index hi = k_first + static_cast<Index>((std::int64_t(k_end) - k_first) * (t + 1) / teams);
    for (const Index* e = std::lower_bound(inner + outer[j], inner + outer[j + 1], lo);
         e != inner + outer[j + 1] && *e < hi; ++e)
      if (d.owns(d.row_of[*e])) visit(*e, static_cast<Index>(e - inner));
  }
};

/// The unknowns of the local rows lie in [k_first, k_end), with other ranks' unknowns between
/// them when the owners are not strips (owns() is checked per entry). Each thread reads every
/// column of A for the entries in its share of that range.
ColumnScan column_scan(const SparseMatrix& A, const Distribution& d) {
  Index k_first = static_cast<Index>(A.rows()), k_end = 0;
  for (LO r = 0; r < d.local_rows(); ++r)
    if (const Index k = d.unknown_of_local[r]; k >= 0) {
      k_first = std::min(k_first, k);
      k_end = std::max(k_end, k + 1);
    }
  return {d, A.outerIndexPtr(), A.innerIndexPtr(), k_first, k_end};
}

/// Pass 1: entries per local row (the diagonal always), and the other ranks' rows touched
/// (sorted, once each).
std::vector<GO> count_entries(const ColumnScan& scan, Index n, std::vector<std::size_t>& count) {
  const Distribution& d = scan.d;
  const int threads = omp_get_max_threads();
  count.assign(static_cast<std::size_t>(d.local_rows()), 1);
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
  return remote;
}

/// Pass 2: each row's diagonal first (stored in A or not), then its other entries in the
/// order of A's columns.
void place_entries(const ColumnScan& scan, Index n, const std::vector<GO>& remote,
                   const RowPointers& row_pointers, const ColumnIndices& column_indices,
                   std::vector<std::size_t>& next) {
  const Distribution& d = scan.d;
  const LO local = d.local_rows();
  auto local_column = [&](GO column) -> LO {
    if (d.owns(column)) return static_cast<LO>(column - d.first_row);
    return local + static_cast<LO>(std::lower_bound(remote.begin(), remote.end(), column) - remote.begin());
  };
  for (LO r = 0; r < local; ++r) {
    column_indices(row_pointers(r)) = r;
    next[r] = row_pointers(r) + 1;
  }
#pragma omp parallel num_threads(omp_get_max_threads())
  {
    const int t = omp_get_thread_num(), teams = omp_get_num_threads();
    for (Index j = 0; j < n; ++j) {
      const LO column = local_column(d.row_of[j]);
      scan(t, teams, j, [&](Index k, Index) {
        if (k == j) return;
        column_indices(next[d.row_of[k] - d.first_row]++) = column;
      });
    }
  }
}

/// Pass 3: each row sorted by local column (Tpetra wants them so); `diagonal` receives the
/// position of each row's diagonal value.
void sort_rows(LO local, const RowPointers& row_pointers, const ColumnIndices& column_indices,
               std::vector<Index>& diagonal) {
#pragma omp parallel for schedule(static)
  for (LO r = 0; r < local; ++r) {
    LO* first = column_indices.data() + row_pointers(r);
    LO* last = column_indices.data() + row_pointers(r + 1);
    std::sort(first, last);
    diagonal[r] = static_cast<Index>(std::lower_bound(first, last, r) - column_indices.data());
  }
}

}  // namespace

Distribution distribute(Index n, const UnknownLayout& layout, int rank, int ranks) {
  if (layout.part()) return distribute_part(n, layout, rank);
  // One process (and a rank's own copy of a whole model, as the MueLu cycle's SerialComm):
  // every row here, two per node in the particles' order when the layout names them.
  if (ranks > 1)
    throw std::logic_error("distribute: under mpirun the unknowns come with a rank's part (UnknownLayout::part())");
  Distribution d;
  d.row_of.resize(n);
  GO nodes = n;
  std::vector<Index> particle_of_node;
  if (static_cast<Index>(layout.component.size()) == n && n > 0) {
    d.per_node = 2;
    const Index particles = *std::max_element(layout.component.begin(), layout.component.end()) / 2 + 1;
    std::vector<Index> node_of(particles, -1);
    for (Index k = 0; k < n; ++k) node_of[layout.component[k] / 2] = 0;
    for (Index p = 0; p < particles; ++p)
      if (node_of[p] == 0) {
        node_of[p] = static_cast<Index>(particle_of_node.size());
        particle_of_node.push_back(p);
      }
    for (Index k = 0; k < n; ++k) d.row_of[k] = 2 * GO(node_of[layout.component[k] / 2]) + layout.component[k] % 2;
    nodes = static_cast<GO>(particle_of_node.size());
  } else {
    std::iota(d.row_of.begin(), d.row_of.end(), GO(0));
  }
  d.n_rows = d.per_node * nodes;
  d.first_row = 0;
  d.unknown_of_local.assign(static_cast<std::size_t>(d.n_rows), -1);
  for (Index k = 0; k < n; ++k) d.unknown_of_local[d.row_of[k]] = k;
  if (d.per_node == 2) {
    d.particle_of_local.resize(d.unknown_of_local.size());
    for (GO q = 0; q < nodes; ++q)
      for (int c = 0; c < 2; ++c) d.particle_of_local[2 * q + c] = particle_of_node[q];
  }
  return d;
}

void TpetraCopy::analyze(const SparseMatrix& A, const UnknownLayout& layout, const RCP<const comm_t>& comm) {
  if (!A.isCompressed()) throw std::logic_error("TpetraCopy::analyze: the matrix must be compressed");
  const Index n = static_cast<Index>(A.rows());
  d = distribute(n, layout, comm->getRank(), comm->getSize());
  const LO local = d.local_rows();
  map = rcp(new map_t(static_cast<Tpetra::global_size_t>(d.n_rows), static_cast<std::size_t>(local), GO(0), comm));
  const ColumnScan scan = column_scan(A, d);
  std::vector<std::size_t> count;
  const std::vector<GO> remote = count_entries(scan, n, count);
  std::vector<GO> columns_of_map(static_cast<std::size_t>(local) + remote.size());
  std::iota(columns_of_map.begin(), columns_of_map.begin() + local, d.first_row);
  std::copy(remote.begin(), remote.end(), columns_of_map.begin() + local);
  const RCP<const map_t> col_map = rcp(new map_t(Teuchos::OrdinalTraits<Tpetra::global_size_t>::invalid(),
                                                 Teuchos::ArrayView<const GO>(columns_of_map), GO(0), comm));
  // The graph takes these views as they are (an ArrayRCP would be copied: 0.64 GB more at the
  // peak of analyze() on a 2000 x 2000 plate).
  RowPointers row_pointers(Kokkos::view_alloc("row pointers", Kokkos::WithoutInitializing), local + 1);
  row_pointers(0) = 0;
  for (LO r = 0; r < local; ++r) row_pointers(r + 1) = row_pointers(r) + count[r];
  const std::size_t nonzeros = row_pointers(local);
  ColumnIndices column_indices(Kokkos::view_alloc("column indices", Kokkos::WithoutInitializing), nonzeros);
  m_diagonal.resize(local);
  place_entries(scan, n, remote, row_pointers, column_indices, count);
  sort_rows(local, row_pointers, column_indices, m_diagonal);
  m_remote_unknown.assign(remote.size(), -1);
  for (Index k = 0; k < n; ++k)
    if (!d.owns(d.row_of[k]))
      if (const auto at = std::lower_bound(remote.begin(), remote.end(), d.row_of[k]);
          at != remote.end() && *at == d.row_of[k])
        m_remote_unknown[at - remote.begin()] = k;
  RCP<graph_t> graph = rcp(new graph_t(map, col_map, row_pointers, column_indices));
  graph->expertStaticFillComplete(map, map);
  m_graph = graph;
  make_matrix();
}

void TpetraCopy::make_matrix() {
  matrix = rcp(new crs_t(m_graph));
  matrix->fillComplete(map, map);
}

void TpetraCopy::fill(const SparseMatrix& A) {
  if (matrix.is_null()) make_matrix();  // after release_values()
  const auto M = matrix->getLocalMatrixHost();
  const auto& row_pointers = M.graph.row_map;
  const LO* column = M.graph.entries.data();
  double* values = M.values.data();
  const Index* outer = A.outerIndexPtr();
  const Index* inner = A.innerIndexPtr();
  const double* a = A.valuePtr();
  const LO local = d.local_rows();
  // Entry (r, c) is A's (k, j), k and j the unknowns of row r and column c: found in column j
  // of A by bisection (A's rows are sorted in each column), or zero where A does not store it
  // (a padding row, a diagonal A lacks). No map from entries to A's positions is kept: at
  // 4 bytes per entry it was 0.57 GB on a 2000 x 2000 plate.
#pragma omp parallel for schedule(static)
  for (LO r = 0; r < local; ++r) {
    const Index k = d.unknown_of_local[r];
    for (std::size_t e = row_pointers(r); e < row_pointers(r + 1); ++e) {
      const LO c = column[e];
      const Index j = c < local ? d.unknown_of_local[c] : m_remote_unknown[c - local];
      double value = 0.0;
      if (k >= 0 && j >= 0) {
        const Index* at = std::lower_bound(inner + outer[j], inner + outer[j + 1], k);
        if (at != inner + outer[j + 1] && *at == k) value = a[at - inner];
      }
      values[e] = value;
    }
  }
  double diagonal_sum = 0.0;
  Index diagonals = 0;
  for (LO r = 0; r < local; ++r)
    if (d.unknown_of_local[r] >= 0) {
      diagonal_sum += std::abs(values[m_diagonal[r]]);
      ++diagonals;
    }
  padding = diagonals > 0 && diagonal_sum > 0.0 ? diagonal_sum / diagonals : 1.0;
  for (LO r = 0; r < local; ++r)
    if (d.unknown_of_local[r] < 0) values[m_diagonal[r]] = padding;
}

RCP<mv_t> TpetraCopy::rigid_body_modes(const UnknownLayout& layout) const {
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

TangentOperator::TangentOperator(RCP<const map_t> map, std::vector<Index> reads, const Distribution& d,
                                 LinearSystem& system, const double& padding)
    : m_map(std::move(map)),
      m_reads(std::move(reads)),
      m_d(d),
      m_system(system),
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

void TangentOperator::apply(const mv_t& X, mv_t& Y, Teuchos::ETransp /*mode*/, double alpha, double beta) const {
  const LO local = m_d.local_rows();
  for (std::size_t c = 0; c < X.getNumVectors(); ++c) {
    m_ghosts->getVectorNonConst(0)->doImport(*X.getVector(c), *m_import, Tpetra::INSERT);
    {
      const Teuchos::ArrayRCP<const double> ghosts = m_ghosts->getData(0);
      for (std::size_t k = 0; k < m_reads.size(); ++k) m_v[m_reads[k]] = ghosts[static_cast<LO>(k)];
    }
    m_system.apply(m_v, m_y);
    const Teuchos::ArrayRCP<const double> x = X.getData(c);
    const Teuchos::ArrayRCP<double> y = Y.getDataNonConst(c);
    for (LO r = 0; r < local; ++r) {
      const Index k = m_d.unknown_of_local[r];
      const double ax = alpha * (k >= 0 ? m_y[k] : m_padding * x[r]);
      y[r] = beta == 0.0 ? ax : ax + beta * y[r];
    }
  }
}

}  // namespace peristat::tpetra
