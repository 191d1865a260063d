#include "assembly/pattern.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include <omp.h>

namespace peristat {

namespace {

/// The rows of a column particle's blocks (build_pattern()).
class RowCollector {
 public:
  RowCollector(const Model& model, PatternReach reach_kind, double radius, const ContactSystem* contact)
      : m_model(model),
        m_bonds(model.bonds),
        m_cons(model.constraints),
        m_reach_kind(reach_kind),
        m_radius2(radius * radius * (1.0 + kBondRadiusMargin)),
        m_contact(contact) {}

  /// Rows of column particle p: {p} + families of p and of each neighbour of p, those that
  /// `keep` accepts, ascending. `seen` is n zeros on entry and on return.
  template <class Keep>
  void collect(Index p, std::vector<Index>& r, std::vector<char>& seen, Keep keep) const {
    const Bonds& bonds = m_bonds;
    const Constraints& cons = m_cons;
    auto add = [&](Index q) {
      if (!seen[q] && keep(q)) {
        seen[q] = 1;
        r.push_back(q);
      }
    };
    // The particles reached from c: its bonds (within the radius) and, for two horizons,
    // their families; `take` filters them.
    const auto reach_from = [&](Index c, auto take) {
      for (Index b = bonds.start[c]; b < bonds.start[c + 1]; ++b) {
        const Index i = bonds.neighbour[b];
        if (m_reach_kind == PatternReach::bonds_within && m_model.xi(c, b).squaredNorm() > m_radius2)
          continue;
        take(i);
        if (m_reach_kind != PatternReach::two_horizons) continue;
        for (Index k = bonds.start[i]; k < bonds.start[i + 1]; ++k) take(bonds.neighbour[k]);
      }
    };
    add(p);
    reach_from(p, add);
    if (m_contact)
      for (auto e = m_contact->incident_begin(p); e != m_contact->incident_end(p); ++e) add(e->other);
    // Mirror ghosts of p: their columns are folded into p's (docs/theory/osb.md, section 7),
    // so p's rows also hold the free rows of each ghost's column.
    if (cons.has_images()) {
      const auto add_free = [&](Index q) {
        if (cons.free_index[2 * q] >= 0 || cons.free_index[2 * q + 1] >= 0) add(q);
      };
      for (Index k = cons.image_start[p]; k < cons.image_start[p + 1]; ++k)
        reach_from(cons.images[k].ghost, add_free);
    }
    std::sort(r.begin(), r.end());
    for (Index q : r) seen[q] = 0;
  }

 private:
  const Model& m_model;
  const Bonds& m_bonds;
  const Constraints& m_cons;
  PatternReach m_reach_kind;
  double m_radius2;
  const ContactSystem* m_contact;
};

/// With owned rows: the owned columns first, whole: the pattern is structurally symmetric, so
/// the particles they reach are exactly the columns that hold an owned row. Those are then
/// collected with owned rows only, and the owned columns cut to their owned rows.
void collect_owned_rows(const RowCollector& collector, const OwnedRows& owned, Index n,
                        std::vector<std::vector<Index>>& rows, TangentPattern& pat) {
  const auto every = [](Index) { return true; };
  const auto mine = [&](Index q) { return owned.contains(q); };
  pat.partial = true;
  std::vector<char> touched(n, 0);
#pragma omp parallel
  {
    std::vector<char> seen(n, 0);
#pragma omp for schedule(dynamic, 256)
    for (Index p = 0; p < n; ++p)
      if (mine(p)) collector.collect(p, rows[p], seen, every);
#pragma omp single
    {
      for (Index p = 0; p < n; ++p)
        if (mine(p))
          for (Index q : rows[p]) touched[q] = 1;
      pat.col_first = n;
      pat.col_end = 0;
      for (Index p = 0; p < n; ++p)
        if (touched[p]) {
          pat.col_first = std::min(pat.col_first, p);
          pat.col_end = p + 1;
        }
      if (pat.col_first > pat.col_end) pat.col_first = pat.col_end;
    }
#pragma omp for schedule(dynamic, 256)
    for (Index p = pat.col_first; p < pat.col_end; ++p) {
      if (!touched[p]) continue;
      if (mine(p))
        std::erase_if(rows[p], [&](Index q) { return !mine(q); });
      else
        collector.collect(p, rows[p], seen, mine);
    }
  }
}

/// The columns' rows into the pattern's arrays (rows freed as they go), its reach and count.
void pack_rows(const Model& model, std::vector<std::vector<Index>>& rows, TangentPattern& pat) {
  const Index n = model.particles.size();
  const Constraints& cons = model.constraints;
  auto n_free_of = [&](Index q) {
    return Index(cons.free_index[2 * q] >= 0) + Index(cons.free_index[2 * q + 1] >= 0);
  };
  pat.col_start.assign(n + 1, 0);
  for (Index p = 0; p < n; ++p) pat.col_start[p + 1] = pat.col_start[p] + static_cast<Index>(rows[p].size());
  pat.row_particle.resize(pat.col_start[n]);
  pat.row_offset.resize(pat.col_start[n]);
  std::vector<Index> col_nnz(n, 0);
  int reach = 0;
  for (Index p = 0; p < n; ++p) {
    Index offset = 0;
    for (std::size_t k = 0; k < rows[p].size(); ++k) {
      const Index q = rows[p][k];
      pat.row_particle[pat.col_start[p] + k] = q;
      pat.row_offset[pat.col_start[p] + k] = offset;
      offset += n_free_of(q);
      for (int a = 0; a < 2; ++a)
        reach = std::max(reach, std::abs(model.particles.lattice[q][a] - model.particles.lattice[p][a]));
    }
    col_nnz[p] = offset;
    std::vector<Index>().swap(rows[p]);
  }
  pat.lattice_reach = reach;
  for (Index p = 0; p < n; ++p) pat.nonzeros += static_cast<long long>(col_nnz[p]) * n_free_of(p);
}

}  // namespace

TangentPattern build_pattern(const Model& model, PatternReach reach_kind, double radius,
                             const ContactSystem* contact, const OwnedRows& owned) {
  const Index n = model.particles.size();
  const RowCollector collector(model, reach_kind, radius, contact);
  TangentPattern pat;
  std::vector<std::vector<Index>> rows(n);
  pat.col_first = 0;
  pat.col_end = n;
  if (owned.all()) {
    const auto every = [](Index) { return true; };
#pragma omp parallel
    {
      std::vector<char> seen(n, 0);
#pragma omp for schedule(dynamic, 256)
      for (Index p = 0; p < n; ++p) collector.collect(p, rows[p], seen, every);
    }
  } else {
    collect_owned_rows(collector, owned, n, rows, pat);
  }
  pack_rows(model, rows, pat);
  return pat;
}

SparseMatrix TangentPattern::make_matrix(const Constraints& cons) const {
  const Index n = static_cast<Index>(col_start.size()) - 1;
  // Free-dof matrix: the columns of particle p (one per free component) share p's rows.
  const Index n_free = cons.n_free;
  std::vector<Index> col_nnz(n, 0);
  for (Index p = 0; p < n; ++p)
    for (Index k = col_start[p]; k < col_start[p + 1]; ++k)
      for (int d = 0; d < 2; ++d) col_nnz[p] += Index(cons.free_index[2 * row_particle[k] + d] >= 0);
  SparseMatrix A(n_free, n_free);
  std::vector<Index> outer(n_free + 1, 0);
  for (Index p = 0; p < n; ++p)
    for (int c = 0; c < 2; ++c)
      if (const Index col = cons.free_index[2 * p + c]; col >= 0) outer[col + 1] = col_nnz[p];
  for (Index col = 0; col < n_free; ++col) outer[col + 1] += outer[col];
  A.resizeNonZeros(outer[n_free]);
  std::copy(outer.begin(), outer.end(), A.outerIndexPtr());
  Index* inner = A.innerIndexPtr();
  double* values = A.valuePtr();
  // Rows and zero values written in parallel: the first touch of these pages (hundreds of
  // MB on large models) is itself a noticeable cost.
#pragma omp parallel for schedule(dynamic, 256)
  for (Index p = 0; p < n; ++p) {
    for (int c = 0; c < 2; ++c) {
      const Index col = cons.free_index[2 * p + c];
      if (col < 0) continue;
      Index pos = outer[col];
      for (Index k = col_start[p]; k < col_start[p + 1]; ++k) {
        const Index q = row_particle[k];
        for (int d = 0; d < 2; ++d)
          if (const Index row = cons.free_index[2 * q + d]; row >= 0) {
            inner[pos] = row;
            values[pos++] = 0.0;
          }
      }
    }
  }
  return A;
}

std::size_t TangentPattern::matrix_bytes() const {
  return static_cast<std::size_t>(nonzeros) * (sizeof(double) + sizeof(Index));
}

std::size_t TangentPattern::memory_bytes() const {
  return (col_start.capacity() + row_particle.capacity() + row_offset.capacity()) * sizeof(Index);
}

}  // namespace peristat
