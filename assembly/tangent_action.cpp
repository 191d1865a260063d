#include "assembly/tangent_action.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace peristat {

// Family i writes rows i and its neighbours, whose lattice points lie within the stencil's
// reach of i's (checked here), so two chunks whose lattice boxes are more than two reaches
// apart along x or y write disjoint rows. Greedy colouring in chunk order.
std::vector<std::vector<Index>> chunk_colours(const Model& model, Index chunk) {
  const Particles& part = model.particles;
  const Bonds& bonds = model.bonds;
  const int reach = model.stencil.reach;
  const Index n = part.size();
  for (Index i = 0; i < n; ++i)
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
      for (int d = 0; d < 2; ++d)
        if (std::abs(part.lattice[bonds.neighbour[b]][d] - part.lattice[i][d]) > reach)
          throw std::logic_error("chunk_colours: a bond longer than the stencil's reach");
  const Index chunks = (n + chunk - 1) / chunk;
  struct Box {
    std::array<int, 2> lo{std::numeric_limits<int>::max(), std::numeric_limits<int>::max()};
    std::array<int, 2> hi{std::numeric_limits<int>::min(), std::numeric_limits<int>::min()};
  };
  std::vector<Box> box(static_cast<std::size_t>(chunks));
  for (Index i = 0; i < n; ++i) {
    Box& x = box[static_cast<std::size_t>(i / chunk)];
    for (int d = 0; d < 2; ++d) {
      x.lo[d] = std::min(x.lo[d], part.lattice[i][d]);
      x.hi[d] = std::max(x.hi[d], part.lattice[i][d]);
    }
  }
  const auto apart = [&](const Box& a, const Box& b) {
    for (int d = 0; d < 2; ++d)
      if (a.lo[d] - b.hi[d] > 2 * reach || b.lo[d] - a.hi[d] > 2 * reach) return true;
    return false;
  };
  std::vector<int> colour(static_cast<std::size_t>(chunks), -1);
  std::vector<std::vector<Index>> colours;
  std::vector<char> taken;
  for (Index c = 0; c < chunks; ++c) {
    taken.assign(colours.size() + 1, 0);
    for (Index o = 0; o < c; ++o)
      if (!apart(box[static_cast<std::size_t>(c)], box[static_cast<std::size_t>(o)]))
        taken[static_cast<std::size_t>(colour[static_cast<std::size_t>(o)])] = 1;
    const auto k = static_cast<std::size_t>(std::find(taken.begin(), taken.end(), 0) - taken.begin());
    if (k == colours.size()) colours.emplace_back();
    colours[k].push_back(c);
    colour[static_cast<std::size_t>(c)] = static_cast<int>(k);
  }
  return colours;
}
std::vector<Index> action_reads(const Model& model, const OwnedRows& rows, const ContactSystem* contact) {
  // The particles whose displacement the own rows' action reads: each own particle, its
  // neighbours and theirs (the dilatation rates of its neighbours' families), and its contact
  // partners; a mirror ghost among them reads its source.
  const Bonds& bonds = model.bonds;
  const Constraints& cons = model.constraints;
  const Index n = model.particles.size();
  std::vector<char> read(static_cast<std::size_t>(n), 0), near(read);
  for (Index q = 0; q < n; ++q) {
    if (!rows.contains(q)) continue;
    near[static_cast<std::size_t>(q)] = 1;
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b)
      near[static_cast<std::size_t>(bonds.neighbour[b])] = 1;
    if (contact)
      for (auto e = contact->incident_begin(q); e != contact->incident_end(q); ++e)
        read[static_cast<std::size_t>(e->other)] = 1;
  }
  for (Index i = 0; i < n; ++i) {
    if (!near[static_cast<std::size_t>(i)]) continue;
    read[static_cast<std::size_t>(i)] = 1;
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
      read[static_cast<std::size_t>(bonds.neighbour[b])] = 1;
  }
  // (A plane mirror puts a read ghost's source within the same reach, by symmetry; the rule
  // holds for any image.)
  return read_unknowns(cons, read);
}

TangentAction::TangentAction(const Model& model, bool matrix_free) : m_model(model) {
  // The chunks: at least 1024 particles, about 128 of them, a function of the particle count
  // alone (the sums' order must not depend on the threads or ranks).
  if (matrix_free) m_colours = chunk_colours(model, m_chunk = std::max<Index>(1024, model.particles.size() / 128));
}

void TangentAction::set_chunk(Index chunk) {
  if (m_chunk == 0) throw std::logic_error("set_action_chunk: the problem is not matrix-free");
  m_colours = chunk_colours(m_model, m_chunk = std::max<Index>(1, chunk));
}

void TangentAction::prepare(const FamilyHessians& h, const ContactSystem* contact, bool fragments,
                            bool families) {
  if (families) pair_stiffness(h);
  if (m_float_copy && !h.single && (families || !m_have_copy)) make_float_copy(h);
  if (contact) {
    m_pair_jacobian.resize(static_cast<std::size_t>(contact->size()));
    for (Index k = 0; k < contact->size(); ++k) m_pair_jacobian[k] = contact->jacobian(k);
  }
  m_fragment_diagonal = fragments ? tangent_diagonal_max(h, contact) : 0.0;
}

void TangentAction::prepare_families(const FamilyHessians& h) {
  pair_stiffness(h);
  if (m_float_copy && !h.single) make_float_copy(h);
}

void TangentAction::set_float_copy(bool on) {
  m_float_copy = on;
  if (!on) {
    release_float_copy();
    return;
  }
  // Held from the start, as the factors are (QuasiStaticProblem::restore_action_storage()):
  // the memory the run reports before its first solve includes it.
  const std::size_t bonds = m_model.bonds.neighbour.size(),
                    n = static_cast<std::size_t>(m_model.particles.size());
  m_s32.assign(bonds, Float2{});
  m_k32.assign(bonds, Float2{});
  m_s_self32.assign(n, Vec2::Zero());
  m_beta_volume32.assign(n, 0.0);
}

void TangentAction::release_float_copy() {
  decltype(m_s32)().swap(m_s32);
  decltype(m_k32)().swap(m_k32);
  m_have_copy = false;
}

void TangentAction::make_float_copy(const FamilyHessians& h) {
  const Bonds& bonds = m_model.bonds;
  const Index n = m_model.particles.size();
  m_s32.resize(bonds.neighbour.size());
  m_k32.resize(bonds.neighbour.size());
  m_s_self32.resize(static_cast<std::size_t>(n));
  m_beta_volume32.resize(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) copy_family(h, i);
  m_have_copy = true;
}

void TangentAction::patch_float_copy(const FamilyHessians& h, std::span<const Index> families) {
  if (!m_float_copy || h.single) return;
  if (!m_have_copy) {
    make_float_copy(h);
    return;
  }
  for (const Index i : families) copy_family(h, i);
}

void TangentAction::copy_family(const FamilyHessians& h, Index i) {
  const Bonds& bonds = m_model.bonds;
  const Index b0 = bonds.start[i], b1 = bonds.start[i + 1];
  double largest = 0.0;
  for (Index b = b0; b < b1; ++b) largest = std::max(largest, h.s[b].cwiseAbs().maxCoeff());
  const int e = largest > 0.0 ? std::ilogb(largest) : 0;
  const double inverse = std::ldexp(1.0, -e);
  for (Index b = b0; b < b1; ++b)
    m_s32[b] = Float2{static_cast<float>(inverse * h.s[b].x()), static_cast<float>(inverse * h.s[b].y())};
  // Reading the floats back, in loops of their own (keep_factors(): GCC 12.2 at -O3 once
  // summed the unrounded doubles of a fused loop).
  Vec2 s = Vec2::Zero();
  for (Index b = b0; b < b1; ++b) s -= widened(m_s32[b]);
  for (Index b = b0; b < b1; ++b) {
    const double full = h.s[b].squaredNorm(), kept = widened(m_s32[b]).squaredNorm();
    m_k32[b] = Float2{static_cast<float>(kept > 0.0 ? h.kbond[b][0] * full / kept : 0.0),
                      static_cast<float>(h.kbond[b][1])};
  }
  m_s_self32[static_cast<std::size_t>(i)] = s;
  m_beta_volume32[static_cast<std::size_t>(i)] = h.beta_volume[i] * std::ldexp(1.0, 2 * e);
}

FamilyHessians TangentAction::float_copy() {
  FamilyHessians f;
  f.s32 = m_s32;
  f.kbond32 = m_k32;
  f.single = true;
  f.s_self = m_s_self32;
  f.beta_volume = m_beta_volume32;
  return f;
}

void TangentAction::apply(const FamilyHessians& h, const ContactSystem* contact, const OwnedRows& rows,
                          const RankShare* share, const std::vector<Index>& fragment_unknowns, const VectorXd& v,
                          VectorXd& y) {
  // K v = gather(H scatter(v)): H the Hessian over every component, its family blocks
  // V_i sum_b B_b^T k_b B_b + beta_i V_i g_i g_i^T (g_i . w = s_self_i . w_i + sum_b s_b . w_j),
  // plus J_e (w_q - w_other) for the contact pairs; scatter() puts sign * v on mirror ghosts
  // (the assembled path's column folds), gather() keeps the unknowns' rows.
  const Index n = m_model.particles.size();
  if (m_colours.empty() && n > 0)
    throw std::logic_error("apply_tangent: the problem was not built matrix-free");
  m_v_free = v;
  for (const Index f : fragment_unknowns) m_v_free[f] = 0.0;  // decoupled: no column
  m_model.constraints.scatter(m_v_free, m_v_full);
  m_y_full.setZero(2 * n);
  // Distributed: this rank's rows only, from the families they read (as the own-rows residual).
  multiply(m_have_copy ? float_copy() : h, contact, rows, share);
  if (share)
    for (const Index q : share->other_particles()) m_y_full[2 * q] = m_y_full[2 * q + 1] = 0.0;
  m_model.constraints.gather(m_y_full, y);
  for (const Index f : fragment_unknowns) y[f] = m_fragment_diagonal * v[f];
  if (share)
    for (const Index f : share->other_unknowns()) y[f] = 0.0;
}

void TangentAction::bond_forces(const FamilyHessians& h, const OwnedRows& rows, const VectorXd& u,
                                VectorXd& f) {
  const Index n = m_model.particles.size();
  if (m_colours.empty() && n > 0)
    throw std::logic_error("TangentAction::bond_forces: the problem was not built matrix-free");
  m_v_full = u;
  m_y_full.setZero(2 * n);
  multiply(h, nullptr, rows, nullptr);
  f.swap(m_y_full);  // f's old storage is the next product's scratch
}

void TangentAction::multiply(const FamilyHessians& h, const ContactSystem* contact, const OwnedRows& rows,
                             const RankShare* share) {
  // Vec2 and BondStiffness: two packed doubles; Float2: two packed floats.
  static_assert(sizeof(Vec2) == 2 * sizeof(double) && sizeof(BondStiffness) == 2 * sizeof(double) &&
                sizeof(Float2) == 2 * sizeof(float));
  if (h.single)
    multiply_on(reinterpret_cast<const float*>(h.s32.data()),
                reinterpret_cast<const float*>(h.kbond32.data()), h, contact, rows, share);
  else
    multiply_on(reinterpret_cast<const double*>(h.s.data()), reinterpret_cast<const double*>(h.kbond.data()),
                h, contact, rows, share);
}

template <class T>
void TangentAction::multiply_on(const T* __restrict s, const T* __restrict k, const FamilyHessians& h,
                                const ContactSystem* contact, const OwnedRows& rows, const RankShare* share) {
  const Index n = m_model.particles.size();
  const bool own = share != nullptr;
  // Raw pointers: the writes into y would otherwise make the compiler reload every vector's
  // data pointer after each bond. The factors s and k are read as T and widened to double.
  const Index* __restrict start = m_model.bonds.start.data();
  const Index* __restrict nbr = m_model.bonds.neighbour.data();
  const auto* __restrict s_self = reinterpret_cast<const double*>(h.s_self.data());
  const double* __restrict beta_volume = h.beta_volume.data();
  const double* __restrict w = m_v_full.data();
  double* __restrict yf = m_y_full.data();
  // One pass over the families, each family's bond data read once from memory and used while
  // it is in cache: the dilatation rate G_i = beta_i V_i g_i . w, then G_i s_self_i into row i
  // and G_i s_b into row j for each bond b = i -> j (the column form of beta_i V_i g_i g_i^T),
  // and each pair's term f = (g I + c_b s_b s_b^T)(w_i - w_j) (pair_stiffness()) once, in the
  // family of its lower index (j > i): f into row i, -f into row j; and row i's contact pairs.
  // On a part, a family another rank's row needs may hold bonds to families not held here:
  // their terms land in rows this rank does not keep (a row's neighbours are all held).
  const auto family = [&](Index i) {
    if (own && !share->family_needed(i)) return;  // none of its terms reaches this rank's rows
    const double wx = w[2 * i], wy = w[2 * i + 1];
    const Index b0 = start[i], b1 = start[i + 1];
    double g = s_self[2 * i] * wx + s_self[2 * i + 1] * wy;
    for (Index b = b0; b < b1; ++b)
      g += double(s[2 * b]) * w[2 * nbr[b]] + double(s[2 * b + 1]) * w[2 * nbr[b] + 1];
    const double G = beta_volume[i] * g;
    double yx = G * s_self[2 * i], yy = G * s_self[2 * i + 1];
    for (Index b = b0; b < b1; ++b) {
      const Index j = nbr[b];
      const double sx = s[2 * b], sy = s[2 * b + 1];
      double ux = G * sx, uy = G * sy;
      if (j > i) {  // the pair's force, once: +f into row i, -f into row j
        const double dx = wx - w[2 * j], dy = wy - w[2 * j + 1];
        const double gk = k[2 * b + 1], c = double(k[2 * b]) * (sx * dx + sy * dy);
        const double fx = gk * dx + c * sx, fy = gk * dy + c * sy;
        yx += fx;
        yy += fy;
        ux -= fx;
        uy -= fy;
      }
      yf[2 * j] += ux;
      yf[2 * j + 1] += uy;
    }
    if (contact && (!own || rows.contains(i)))
      for (auto e = contact->incident_begin(i); e != contact->incident_end(i); ++e)
        if (e->pair < static_cast<Index>(m_pair_jacobian.size())) {  // pairs added since: none yet
          const Vec2 f = m_pair_jacobian[e->pair] * Vec2(wx - w[2 * e->other], wy - w[2 * e->other + 1]);
          yx += f.x();
          yy += f.y();
        }
    yf[2 * i] += yx;
    yf[2 * i + 1] += yy;
  };
  // Chunks of a colour write disjoint rows (chunk_colours()): they run in parallel, colour by
  // colour. Each row sums its terms in an order fixed by the particles alone.
#pragma omp parallel
  for (const std::vector<Index>& colour : m_colours) {
    const auto count = static_cast<Index>(colour.size());
#pragma omp for schedule(dynamic, 1)
    for (Index c = 0; c < count; ++c) {
      const Index begin = colour[static_cast<std::size_t>(c)] * m_chunk, end = std::min(begin + m_chunk, n);
      for (Index i = begin; i < end; ++i) family(i);
    }
  }
}

namespace {
/// A bond's s_b or factor pair as doubles, kept in double (Vec2, BondStiffness); a Float2 is
/// family_kernel.hpp's widened().
inline Vec2 widened(const Vec2& v) {
  return v;
}
inline Vec2 widened(const BondStiffness& k) {
  return Vec2(k[0], k[1]);
}
}  // namespace

void TangentAction::pair_stiffness(const FamilyHessians& h) const {
  if (h.single)
    pair_stiffness_on(h.s32, h.kbond32);
  else
    pair_stiffness_on(h.s, h.kbond);
}

template <class S, class K>
void TangentAction::pair_stiffness_on(std::span<const S> s, std::span<K> kbond) const {
  using Kept = typename K::value_type;
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const Index n = part.size();
  // Each pair {b, r} once, by the family of its lower bond index: no two iterations write
  // the same bond. In double from the kept factors (rounded ones with float), |s_b|^2 of the
  // s_b that apply() reads.
#pragma omp parallel for schedule(static)
  for (Index q = 0; q < n; ++q)
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b) {
      const Index r = bonds.reverse(q, b);
      if (r < b) continue;
      const PairForm f =
          pair_form(part.volume[q], part.volume[bonds.neighbour[b]], widened(kbond[b]), widened(kbond[r]),
                    widened(s[b]).squaredNorm(), widened(s[r]).squaredNorm());
      kbond[b] = K{static_cast<Kept>(f.c_lower), static_cast<Kept>(f.g)};
      kbond[r] = K{static_cast<Kept>(f.c_upper), static_cast<Kept>(f.g)};
    }
}

double TangentAction::tangent_diagonal_max(const FamilyHessians& h, const ContactSystem* contact) const {
  return h.single ? tangent_diagonal_max_on(h.s32, std::span<const Float2>(h.kbond32), h, contact)
                  : tangent_diagonal_max_on(h.s, std::span<const BondStiffness>(h.kbond), h, contact);
}

template <class S, class K>
double TangentAction::tangent_diagonal_max_on(std::span<const S> s, std::span<const K> kbond,
                                              const FamilyHessians& h, const ContactSystem* contact) const {
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const std::vector<Index>& free = m_model.constraints.free_index;
  double largest = 0.0;
  for (Index q = 0; q < part.size(); ++q) {
    Vec2 d(h.beta_volume[q] * h.s_self[q].x() * h.s_self[q].x(), h.beta_volume[q] * h.s_self[q].y() * h.s_self[q].y());
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b) {  // pair_stiffness()'s data
      const Index r = bonds.reverse(q, b);  // -1: the neighbour's family is another rank's
      const Vec2 sr = r >= 0 ? widened(s[r]) : Vec2::Zero();
      const double bVj = h.beta_volume[bonds.neighbour[b]];
      const Vec2 sb = widened(s[b]), k = widened(kbond[b]);
      d.x() += k[1] + k[0] * sb.x() * sb.x() + bVj * sr.x() * sr.x();
      d.y() += k[1] + k[0] * sb.y() * sb.y() + bVj * sr.y() * sr.y();
    }
    if (contact)
      for (auto e = contact->incident_begin(q); e != contact->incident_end(q); ++e) {
        d.x() += m_pair_jacobian[e->pair](0, 0);
        d.y() += m_pair_jacobian[e->pair](1, 1);
      }
    for (int c = 0; c < 2; ++c)
      if (free[2 * q + c] >= 0) largest = std::max(largest, std::abs(d[c]));
  }
  return largest;
}

std::size_t TangentAction::memory_bytes() const {
  std::size_t colours = 0;
  for (const std::vector<Index>& c : m_colours) colours += c.capacity() * sizeof(Index);
  return colours + m_pair_jacobian.capacity() * sizeof(Mat2) +
         static_cast<std::size_t>(m_v_free.size() + m_v_full.size() + m_y_full.size()) * sizeof(double) +
         (m_s32.capacity() + m_k32.capacity()) * sizeof(Float2) + m_s_self32.capacity() * sizeof(Vec2) +
         m_beta_volume32.capacity() * sizeof(double);
}

}  // namespace peristat
