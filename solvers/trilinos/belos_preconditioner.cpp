#include "solvers/trilinos/belos_preconditioner.hpp"

#include <exception>

#include <Ifpack2_Factory.hpp>
#include <MueLu_CreateTpetraPreconditioner.hpp>

namespace peristat::tpetra {

BlockFactor::BlockFactor(RCP<const map_t> map) : m_map(std::move(map)) {
  m_factor.cholmod().print = 0;  // failures reach the user through info()
}

bool BlockFactor::factorize(const SparseMatrix& P, const Distribution& d, double padding) {
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

void BlockFactor::apply(const mv_t& X, mv_t& Y, Teuchos::ETransp /*mode*/, double alpha, double beta) const {
  for (std::size_t v = 0; v < X.getNumVectors(); ++v) {
    const Teuchos::ArrayRCP<const double> x = X.getData(v);
    const Teuchos::ArrayRCP<double> y = Y.getDataNonConst(v);
    for (Index i = 0; i < m_in.size(); ++i) m_in[i] = x[i];
    m_out = m_factor.solve(m_in);
    for (Index i = 0; i < m_out.size(); ++i) y[i] = beta == 0.0 ? alpha * m_out[i] : alpha * m_out[i] + beta * y[i];
  }
}

void BelosPreconditioners::drop(bool pattern) {
  m_preconditioner = Teuchos::null;
  m_muelu = Teuchos::null;
  if (!pattern) return;
  m_ifpack2 = Teuchos::null;
  m_block = Teuchos::null;
}

Eigen::ComputationInfo BelosPreconditioners::build(BelosPreconditioner kind, const TpetraCopy& copy,
                                                   const UnknownLayout& layout,
                                                   const Teuchos::ParameterList& muelu_parameters,
                                                   const SparseMatrix* P) {
  try {
    switch (kind) {
      case BelosPreconditioner::muelu:
        build_muelu(copy, layout, muelu_parameters);
        break;
      case BelosPreconditioner::ifpack2_ilut:
      case BelosPreconditioner::ifpack2_relaxation:
        build_ifpack2(kind, copy);
        break;
      case BelosPreconditioner::bond_factor:
        return build_bond_factor(copy, P);
    }
  } catch (const std::exception&) {  // a Trilinos failure (e.g. a zero pivot): the seam's terms
    m_preconditioner = Teuchos::null;
    return Eigen::NumericalIssue;
  }
  return Eigen::Success;
}

void BelosPreconditioners::build_muelu(const TpetraCopy& copy, const UnknownLayout& layout,
                                       const Teuchos::ParameterList& parameters) {
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
  p.setParameters(parameters);  // the user's list wins
  if (copy.d.per_node == 2) {
    p.set("number of equations", 2);
    p.sublist("user data").set("Nullspace", copy.rigid_body_modes(layout));
  }
  m_muelu = MueLu::CreateTpetraPreconditioner(RCP<op_t>(copy.matrix), p);
  m_preconditioner = m_muelu;
}

void BelosPreconditioners::build_ifpack2(BelosPreconditioner kind, const TpetraCopy& copy) {
  if (m_ifpack2.is_null()) {
    m_ifpack2 = Ifpack2::Factory::create<row_t>("SCHWARZ", RCP<const row_t>(copy.matrix));
    Teuchos::ParameterList p;
    p.set("schwarz: overlap level", 0);
    if (kind == BelosPreconditioner::ifpack2_ilut) {
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
}

Eigen::ComputationInfo BelosPreconditioners::build_bond_factor(const TpetraCopy& copy, const SparseMatrix* P) {
  if (P == nullptr || P->rows() != static_cast<Index>(copy.d.row_of.size())) return Eigen::InvalidInput;
  if (m_block.is_null()) m_block = rcp(new BlockFactor(copy.map));
  if (!m_block->factorize(*P, copy.d, copy.padding)) return Eigen::NumericalIssue;
  m_preconditioner = m_block;
  return Eigen::Success;
}

}  // namespace peristat::tpetra
