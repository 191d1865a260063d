#include "solvers/trilinos/threaded_cycle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include <Ifpack2_Chebyshev.hpp>
#include <Ifpack2_Relaxation.hpp>
#include <MueLu_Ifpack2Smoother.hpp>
#include <MueLu_TrilinosSmoother.hpp>
#include <MueLu_Utilities.hpp>

namespace peristat {

namespace {

using Teuchos::RCP;
using Teuchos::rcp_dynamic_cast;
using LO = ThreadedCycle::LO;
using GO = ThreadedCycle::GO;
using NT = ThreadedCycle::NT;
using matrix_t = Xpetra::Matrix<double, LO, GO, NT>;
using operator_t = Xpetra::Operator<double, LO, GO, NT>;
using row_t = Tpetra::RowMatrix<double, LO, GO, NT>;
using local_t = ThreadedCycle::crs_t::local_matrix_host_type;

/// The Tpetra matrix behind level data `name` (an Xpetra wrapper), or null.
RCP<const ThreadedCycle::crs_t> tpetra_matrix(MueLu::Level& level, const std::string& name) {
  if (!level.IsAvailable(name)) return Teuchos::null;
  const RCP<matrix_t> m = rcp_dynamic_cast<matrix_t>(level.Get<RCP<operator_t>>(name));
  if (m.is_null()) return Teuchos::null;
  try {
    return MueLu::Utilities<double, LO, GO, NT>::Op2TpetraCrs(RCP<const matrix_t>(m));
  } catch (const std::exception&) {
    return Teuchos::null;
  }
}

/// Local column indices are the domain's rows (one process: the column map is the domain map).
bool columns_are_domain(const ThreadedCycle::crs_t& m) {
  return m.getColMap()->isSameAs(*m.getDomainMap());
}

// The kernels. Each row is one thread's, so the results do not depend on the thread count.

/// b_i - (A x)_i
inline double row_residual(const local_t& A, const double* b, const double* x, LO i) {
  const auto* row = A.graph.row_map.data();
  const LO* col = A.graph.entries.data();
  const double* a = A.values.data();
  double s = b[i];
  for (auto k = row[i]; k < row[i + 1]; ++k) s -= a[k] * x[col[k]];
  return s;
}

/// b_i - (A x)_i for rows i = 2p and 2p + 1 of a blocked matrix with values `a` (doubles or
/// floats, the arithmetic in doubles): the same subtractions in the same order as
/// row_residual() on the CSR rows (a zero entry subtracts an exact zero).
template <class Value>
inline void block_residual(const ThreadedCycle::Blocks& B, const Value* a, const double* b, const double* x,
                           LO p, double& r0, double& r1) {
  double s0 = b[2 * p], s1 = b[2 * p + 1];
  const LO* col = B.col.data();
  for (std::size_t k = B.start[p]; k < B.start[p + 1]; ++k) {
    const double x0 = x[2 * col[k]], x1 = x[2 * col[k] + 1];
    const Value* blk = a + 4 * k;
    s0 -= static_cast<double>(blk[0]) * x0;
    s1 -= static_cast<double>(blk[1]) * x0;
    s0 -= static_cast<double>(blk[2]) * x1;
    s1 -= static_cast<double>(blk[3]) * x1;
  }
  r0 = s0;
  r1 = s1;
}

/// f(i, (b - A x)_i) for every row i, each row one thread's: from the blocks (of doubles or
/// floats) when there are, else from the CSR matrix.
template <class F>
void for_each_residual(const local_t& A, const ThreadedCycle::Blocks& B, const double* b, const double* x,
                       F&& f) {
  const auto by_blocks = [&](const auto* a) {
    const auto blocks = static_cast<LO>(B.start.size() - 1);
#pragma omp parallel for schedule(static)
    for (LO p = 0; p < blocks; ++p) {
      double s0, s1;
      block_residual(B, a, b, x, p, s0, s1);
      f(2 * p, s0);
      f(2 * p + 1, s1);
    }
  };
  if (B.empty()) {
    const LO n = A.numRows();
#pragma omp parallel for schedule(static)
    for (LO i = 0; i < n; ++i) f(i, row_residual(A, b, x, i));
  } else if (B.values.empty()) {
    by_blocks(B.rounded.data());
  } else {
    by_blocks(B.values.data());
  }
}

/// r = b - A x
void residual(const local_t& A, const ThreadedCycle::Blocks& B, const double* b, const double* x, double* r) {
  for_each_residual(A, B, b, x, [r](LO i, double s) { r[i] = s; });
}

/// w = c1 D^-1 (b - A x) + c2 w, then x += w (c2 = 0: w's old values are not read).
void scaled_residual_step(const local_t& A, const ThreadedCycle::Blocks& B, const double* d_inv,
                          const double* b, double* x, double* w, double c1, double c2) {
  const LO n = A.numRows();
  for_each_residual(A, B, b, x, [&](LO i, double s) {
    w[i] = c2 == 0.0 ? c1 * d_inv[i] * s : c1 * d_inv[i] * s + c2 * w[i];
  });
#pragma omp parallel for schedule(static)
  for (LO i = 0; i < n; ++i) x[i] += w[i];
}

/// A's rows in 2 x 2 blocks, or empty if A has an odd number of rows; `rounded`: the values
/// as floats, unless a non-zero one is beyond a float's range or subnormal as one (then doubles).
ThreadedCycle::Blocks to_blocks(const local_t& A, bool rounded) {
  ThreadedCycle::Blocks B;
  const LO n = A.numRows();
  if (n % 2 != 0) return B;
  const auto* row = A.graph.row_map.data();
  const LO* col = A.graph.entries.data();
  const double* a = A.values.data();
  const LO blocks = n / 2;
  const auto nonzeros = static_cast<std::ptrdiff_t>(row[n]);
  // Floats only where every entry keeps its 24 bits: none beyond a float's range, and no
  // non-zero one among the subnormals (a scene in extreme units; it keeps doubles).
  const bool to_float = rounded && std::all_of(a, a + nonzeros, [](double v) {
                          const double m = std::abs(v);
                          return m == 0.0 || (m >= static_cast<double>(std::numeric_limits<float>::min()) &&
                                              m <= static_cast<double>(std::numeric_limits<float>::max()));
                        });
  B.start.assign(static_cast<std::size_t>(blocks) + 1, 0);
  // Two passes over the block rows, each row one thread's: the block counts, then (after
  // their prefix sum) the columns and values.
  for (int pass = 0; pass < 2; ++pass) {
#pragma omp parallel
    {
      std::vector<LO> cols;
#pragma omp for schedule(static)
      for (LO p = 0; p < blocks; ++p) {
        cols.clear();
        for (LO i = 2 * p; i <= 2 * p + 1; ++i)
          for (auto k = row[i]; k < row[i + 1]; ++k) cols.push_back(col[k] / 2);
        std::sort(cols.begin(), cols.end());
        cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
        if (pass == 0) {
          B.start[static_cast<std::size_t>(p) + 1] = cols.size();
          continue;
        }
        const std::size_t first = B.start[static_cast<std::size_t>(p)];
        std::copy(cols.begin(), cols.end(), B.col.begin() + static_cast<std::ptrdiff_t>(first));
        for (LO c = 0; c < 2; ++c) {
          const LO i = 2 * p + c;
          for (auto k = row[i]; k < row[i + 1]; ++k) {
            const std::size_t blk =
                first + static_cast<std::size_t>(std::lower_bound(cols.begin(), cols.end(), col[k] / 2) -
                                                 cols.begin());
            const std::size_t at = 4 * blk + static_cast<std::size_t>(2 * (col[k] % 2) + c);
            if (to_float)
              B.rounded[at] = static_cast<float>(a[k]);
            else
              B.values[at] = a[k];
          }
        }
      }
    }
    if (pass == 0) {
      for (std::size_t p = 0; p < static_cast<std::size_t>(blocks); ++p) B.start[p + 1] += B.start[p];
      B.col.assign(B.start.back(), 0);
      if (to_float)
        B.rounded.assign(4 * B.start.back(), 0.0f);
      else
        B.values.assign(4 * B.start.back(), 0.0);
    }
  }
  return B;
}

/// x = c D^-1 b (and w = x)
void scaled_diagonal(LO n, const double* d_inv, const double* b, double* x, double* w, double c) {
#pragma omp parallel for schedule(static)
  for (LO i = 0; i < n; ++i) {
    w[i] = c * d_inv[i] * b[i];
    x[i] = w[i];
  }
}

}  // namespace

bool ThreadedCycle::read_smoother(const RCP<MueLu::SmootherBase<double, LO, GO, NT>>& s, Smoother& out,
                                  std::string& why_not) {
  using ifpack_smoother_t = MueLu::Ifpack2Smoother<double, LO, GO, NT>;
  using trilinos_smoother_t = MueLu::TrilinosSmoother<double, LO, GO, NT>;
  RCP<ifpack_smoother_t> smoother = rcp_dynamic_cast<ifpack_smoother_t>(s);
  if (const RCP<trilinos_smoother_t> wrapper = rcp_dynamic_cast<trilinos_smoother_t>(s); !wrapper.is_null())
    smoother = rcp_dynamic_cast<ifpack_smoother_t>(wrapper->getSmoother());  // the wrapper's Tpetra smoother
  if (smoother.is_null()) {
    why_not = "a smoother that is not Ifpack2's: " + (s.is_null() ? std::string("null") : s->description());
    return false;
  }
  const Teuchos::ParameterList& list = smoother->GetParameterList();
  const RCP<Ifpack2::Preconditioner<double, LO, GO, NT>> prec = smoother->getPreconditioner();
  // Ifpack2 fills its defaults into the list; a parameter set to anything else must be one
  // whose arithmetic is repeated here.
  auto only = [&](const std::set<std::string>& known) {
    for (auto it = list.begin(); it != list.end(); ++it)
      if (!list.entry(it).isDefault() && !known.count(list.name(it))) {
        why_not = "smoother parameter \"" + list.name(it) + "\"";
        return false;
      }
    return true;
  };
  if (const auto chebyshev = rcp_dynamic_cast<Ifpack2::Chebyshev<row_t>>(prec); !chebyshev.is_null()) {
    if (!only({"chebyshev: degree", "chebyshev: ratio eigenvalue", "chebyshev: max eigenvalue",
               "chebyshev: boost factor", "chebyshev: min diagonal value",
               "chebyshev: zero starting solution",
               "chebyshev: eigenvalue max iterations"}))  // the last: the set-up's estimate
      return false;
    out.kind = Smoother::Kind::chebyshev;
    out.degree = list.isParameter("chebyshev: degree") ? list.get<int>("chebyshev: degree") : 1;
    out.ratio = list.isParameter("chebyshev: ratio eigenvalue")
                    ? list.get<double>("chebyshev: ratio eigenvalue")
                    : 30.0;
    out.boost =
        list.isParameter("chebyshev: boost factor") ? list.get<double>("chebyshev: boost factor") : 1.1;
    out.min_diagonal = list.isParameter("chebyshev: min diagonal value")
                           ? list.get<double>("chebyshev: min diagonal value")
                           : std::numeric_limits<double>::epsilon();
    out.lambda_max = chebyshev->getLambdaMaxForApply();
    if (!std::isfinite(out.lambda_max) || out.lambda_max <= 0.0 || !(out.ratio >= 1.0)) {
      why_not = "a Chebyshev smoother without an eigenvalue estimate";
      return false;
    }
    return true;
  }
  if (const auto relaxation = rcp_dynamic_cast<Ifpack2::Relaxation<row_t>>(prec); !relaxation.is_null()) {
    if (!only({"relaxation: type", "relaxation: sweeps", "relaxation: damping factor",
               "relaxation: zero starting solution"}))
      return false;
    if (list.isParameter("relaxation: type") && list.get<std::string>("relaxation: type") != "Jacobi") {
      why_not = "relaxation other than Jacobi";
      return false;
    }
    out.kind = Smoother::Kind::jacobi;
    out.degree = list.isParameter("relaxation: sweeps") ? list.get<int>("relaxation: sweeps") : 1;
    out.damping =
        list.isParameter("relaxation: damping factor") ? list.get<double>("relaxation: damping factor") : 1.0;
    return true;
  }
  why_not = "an Ifpack2 smoother other than Chebyshev or Jacobi";
  return false;
}

bool ThreadedCycle::read_smoothing(MueLu::Level& L, int i, Level& level, std::string& why_not) {
  if (L.IsAvailable("PreSmoother") &&
      !read_smoother(L.Get<RCP<MueLu::SmootherBase<double, LO, GO, NT>>>("PreSmoother"), level.pre,
                     why_not))
    return false;
  if (L.IsAvailable("PostSmoother") &&
      !read_smoother(L.Get<RCP<MueLu::SmootherBase<double, LO, GO, NT>>>("PostSmoother"), level.post,
                     why_not))
    return false;
  // D^-1 as Ifpack2 computes it (Details::Chebyshev's reciprocal_threshold): an entry below
  // the threshold t in magnitude gets t itself, not 1 / t (that row is barely smoothed);
  // Jacobi's threshold is 0.
  if (level.pre.kind != Smoother::Kind::none && level.post.kind != Smoother::Kind::none &&
      level.pre.min_diagonal != level.post.min_diagonal) {
    why_not = "level " + std::to_string(i) + " smooths with two diagonal thresholds";
    return false;
  }
  const double threshold =
      level.pre.kind != Smoother::Kind::none ? level.pre.min_diagonal : level.post.min_diagonal;
  const LO n = level.A.numRows();
  level.d_inv.assign(static_cast<std::size_t>(n), 0.0);
  const auto* row = level.A.graph.row_map.data();
  const LO* col = level.A.graph.entries.data();
  const double* a = level.A.values.data();
  for (LO r = 0; r < n; ++r)
    for (auto k = row[r]; k < row[r + 1]; ++k)
      if (col[k] == r) level.d_inv[r] = std::abs(a[k]) < threshold ? threshold : 1.0 / a[k];
  if (!std::all_of(level.d_inv.begin(), level.d_inv.end(), [](double v) { return std::isfinite(v); })) {
    why_not = "level " + std::to_string(i) + " has a zero diagonal entry (Jacobi)";
    return false;
  }
  return true;
}

std::unique_ptr<ThreadedCycle> ThreadedCycle::from(hierarchy_t& h, std::string& why_not, Finest finest,
                                                   int pre_degree) {
  std::unique_ptr<ThreadedCycle> c(new ThreadedCycle);
  if (h.GetCycle() != MueLu::VCYCLE) {
    why_not = "not a V-cycle";
    return nullptr;
  }
  const int levels = h.GetNumLevels();
  c->m_levels.resize(static_cast<std::size_t>(levels));
  RCP<const crs_t> finer;
  for (int i = 0; i < levels; ++i) {
    MueLu::Level& L = *h.GetLevel(i);
    Level& level = c->m_levels[static_cast<std::size_t>(i)];
    const RCP<const crs_t> A = tpetra_matrix(L, "A");
    if (A.is_null()) {
      why_not = "level " + std::to_string(i) + " has no Tpetra matrix";
      return nullptr;
    }
    if (A->getComm()->getSize() != 1 || !columns_are_domain(*A) ||
        !A->getRowMap()->isSameAs(*A->getDomainMap())) {
      why_not = "level " + std::to_string(i) + " is distributed";
      return nullptr;
    }
    level.A = A->getLocalMatrixHost();
    if (i == 0 && finest != Finest::csr) level.blocks = to_blocks(level.A, finest == Finest::float_blocks);
    if (i > 0) {
      if ((L.IsAvailable("Importer") &&
           !L.Get<RCP<const Xpetra::Import<LO, GO, NT>>>("Importer").is_null()) ||
          L.IsAvailable("Pbar")) {
        why_not = "level " + std::to_string(i) + " is rebalanced";
        return nullptr;
      }
      const RCP<const crs_t> P = tpetra_matrix(L, "P");
      if (P.is_null() || !columns_are_domain(*P) || !P->getDomainMap()->isSameAs(*A->getRowMap()) ||
          !P->getRowMap()->isSameAs(*finer->getRowMap())) {
        why_not = "level " + std::to_string(i) + "'s prolongator does not map between the levels' rows";
        return nullptr;
      }
      c->m_levels[static_cast<std::size_t>(i - 1)].P = P->getLocalMatrixHost();
    }
    finer = A;
    if (!read_smoothing(L, i, level, why_not)) return nullptr;
    if (pre_degree > 0 && level.pre.kind == Smoother::Kind::chebyshev)
      level.pre.degree = std::min(level.pre.degree, pre_degree);
    const LO n = level.A.numRows();
    if (i > 0) {  // the finest level's are the caller's
      level.b.assign(static_cast<std::size_t>(n), 0.0);
      level.x.assign(static_cast<std::size_t>(n), 0.0);
    }
    level.work.assign(static_cast<std::size_t>(n), 0.0);
  }
  // The finest level read in blocks: its CSR values are not read again (its graph gives the
  // rows), and the cycle no longer holds them (their owner may drop them).
  if (!c->m_levels[0].blocks.empty()) c->m_levels[0].A.values = decltype(local_t::values)();
  for (int i = 0; i + 1 < levels; ++i) {
    Level& level = c->m_levels[static_cast<std::size_t>(i)];
    level.chunks.assign(static_cast<std::size_t>(kChunks) * c->m_levels[i + 1].b.size(), 0.0);
  }
  return c;
}

void ThreadedCycle::apply(const double* b, double* x) {
  cycle(0, b, x);
}

double ThreadedCycle::matrix_bytes_per_apply() const {
  const auto csr_bytes = [](const local_t& M) {
    return static_cast<double>(M.nnz()) * (sizeof(double) + sizeof(LO)) +
           (M.numRows() + 1.0) * sizeof(std::size_t);
  };
  // Sweeps of a level's matrix by a smoother (scaled_residual_step calls in smooth()).
  const auto sweeps = [](const Smoother& s, bool zero_guess) {
    if (s.kind == Smoother::Kind::none) return 0;
    if (s.kind == Smoother::Kind::chebyshev && std::abs(s.lambda_max - 1.0) < 1e-6) return 0;
    return zero_guess ? s.degree - 1 : s.degree;
  };
  double bytes = 0.0;
  for (std::size_t l = 0; l < m_levels.size(); ++l) {
    const Level& level = m_levels[l];
    const bool coarsest = l + 1 == m_levels.size();
    const Blocks& k = level.blocks;
    const double a = k.empty() ? csr_bytes(level.A)
                               : static_cast<double>(k.start.size()) * sizeof(std::size_t) +
                                     static_cast<double>(k.col.size()) * sizeof(LO) +
                                     static_cast<double>(k.values.size()) * sizeof(double) +
                                     static_cast<double>(k.rounded.size()) * sizeof(float);
    const bool pre = level.pre.kind != Smoother::Kind::none;
    int n = sweeps(level.pre, true) + (coarsest ? sweeps(level.post, !pre) : 1 + sweeps(level.post, false));
    bytes += n * a;
    if (!coarsest) bytes += 2.0 * csr_bytes(level.P);
  }
  return bytes;
}

void ThreadedCycle::smooth(Level& level, const Smoother& s, const double* b, double* x, bool zero_guess) {
  const LO n = level.A.numRows();
  double* w = level.work.data();  // the smoother's W (the residual is not live while it smooths)
  const double* d_inv = level.d_inv.data();
  if (s.kind == Smoother::Kind::jacobi) {
    // Ifpack2::Relaxation, Jacobi: x = w D^-1 b from zero, then x += w D^-1 (b - A x).
    for (int sweep = 0; sweep < s.degree; ++sweep) {
      if (sweep == 0 && zero_guess)
        scaled_diagonal(n, d_inv, b, x, w, s.damping);
      else
        scaled_residual_step(level.A, level.blocks, d_inv, b, x, w, s.damping, 0.0);
    }
    return;
  }
  // Ifpack2::Details::Chebyshev::ifpackApplyImpl, with its estimates: eigenvalues of D^-1 A in
  // [alpha, beta] = [lambda_max / ratio, boost lambda_max]; a lambda_max of 1 means A is
  // (a multiple of) its diagonal, solved exactly.
  if (std::abs(s.lambda_max - 1.0) < 1e-6) {
    scaled_diagonal(n, d_inv, b, x, w, 1.0);
    return;
  }
  const double alpha = s.lambda_max / s.ratio, beta = s.boost * s.lambda_max;
  const double delta = 2.0 / (beta - alpha), theta = 0.5 * (beta + alpha), s1 = theta * delta;
  if (zero_guess)
    scaled_diagonal(n, d_inv, b, x, w, 1.0 / theta);
  else
    scaled_residual_step(level.A, level.blocks, d_inv, b, x, w, 1.0 / theta, 0.0);
  double rho = 1.0 / s1;
  for (int k = 1; k < s.degree; ++k) {
    const double rho_next = 1.0 / (2.0 * s1 - rho);
    const double c2 = rho_next * rho, c1 = 2.0 * rho_next * delta;
    rho = rho_next;
    scaled_residual_step(level.A, level.blocks, d_inv, b, x, w, c1, c2);
  }
}

// Hierarchy::Iterate for one V-cycle from a zero guess: pre-smooth, restrict the residual,
// cycle on the next level, prolongate and add, post-smooth; the coarsest level is its
// smoothers (pre from zero, then post).
void ThreadedCycle::cycle(std::size_t l, const double* b, double* x) {
  Level& level = m_levels[l];
  const LO n = level.A.numRows();
  const bool coarsest = l + 1 == m_levels.size();
  bool zero_guess = true;
  if (level.pre.kind != Smoother::Kind::none) {
    smooth(level, level.pre, b, x, true);
    zero_guess = false;
  }
  if (coarsest) {
    if (level.post.kind != Smoother::Kind::none) {
      smooth(level, level.post, b, x, zero_guess);
      zero_guess = false;
    }
    if (zero_guess) std::copy(b, b + n, x);  // no coarse solver: the identity, as MueLu
    return;
  }
  if (zero_guess) std::fill(x, x + n, 0.0);
  double* r = level.work.data();  // the residual (the smoother's W is not live here)
  residual(level.A, level.blocks, b, x, r);
  // b_c = P^T r: kChunks fixed row ranges scatter into their own buffers, added in order.
  Level& coarse = m_levels[l + 1];
  const LO nc = coarse.A.numRows();
  {
    const local_t& P = level.P;
    const auto* row = P.graph.row_map.data();
    const LO* col = P.graph.entries.data();
    const double* p = P.values.data();
    double* chunks = level.chunks.data();
#pragma omp parallel for schedule(static)
    for (int c = 0; c < kChunks; ++c) {
      double* y = chunks + static_cast<std::size_t>(c) * nc;
      std::fill(y, y + nc, 0.0);
      const LO begin = static_cast<LO>(static_cast<long long>(n) * c / kChunks);
      const LO end = static_cast<LO>(static_cast<long long>(n) * (c + 1) / kChunks);
      for (LO i = begin; i < end; ++i)
        for (auto k = row[i]; k < row[i + 1]; ++k) y[col[k]] += p[k] * r[i];
    }
    double* bc = coarse.b.data();
#pragma omp parallel for schedule(static)
    for (LO j = 0; j < nc; ++j) {
      double s = 0.0;
      for (int c = 0; c < kChunks; ++c) s += chunks[static_cast<std::size_t>(c) * nc + j];
      bc[j] = s;
    }
  }
  cycle(l + 1, coarse.b.data(), coarse.x.data());

  {  // x += P x_c
    const local_t& P = level.P;
    const auto* row = P.graph.row_map.data();
    const LO* col = P.graph.entries.data();
    const double* p = P.values.data();
    const double* xc = coarse.x.data();
#pragma omp parallel for schedule(static)
    for (LO i = 0; i < n; ++i) {
      double s = 0.0;
      for (auto k = row[i]; k < row[i + 1]; ++k) s += p[k] * xc[col[k]];
      x[i] += s;
    }
  }
  if (level.post.kind != Smoother::Kind::none) smooth(level, level.post, b, x, false);
}

}  // namespace peristat
