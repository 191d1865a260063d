#include "solvers/trilinos/partition.hpp"

#include <numeric>
#include <stdexcept>
#include <string>

#include <Teuchos_DefaultMpiComm.hpp>
#include <Teuchos_ParameterList.hpp>
#include <Zoltan2_BasicVectorAdapter.hpp>
#include <Zoltan2_PartitioningProblem.hpp>

#include "solvers/trilinos/tpetra_start.hpp"

namespace peristat {

std::vector<int> rcb_parts(const std::vector<double>& x, const std::vector<double>& y, int parts) {
  const std::size_t n = x.size();
  if (y.size() != n) throw std::logic_error("rcb_parts: x and y differ in length");
  if (parts <= 1 || n == 0) return std::vector<int>(n, 0);
  using types_t = Zoltan2::BasicUserTypes<double, int, long long>;
  using adapter_t = Zoltan2::BasicVectorAdapter<types_t>;
  std::vector<long long> ids(n);
  std::iota(ids.begin(), ids.end(), 0LL);
  adapter_t adapter(static_cast<int>(n), ids.data(), x.data(), y.data(), nullptr, 1, 1, 1);
  Teuchos::ParameterList params("rcb");
  params.set("algorithm", "rcb");
  params.set("num_global_parts", parts);
  params.sublist("zoltan_parameters").set("DEBUG_LEVEL", "0");  // Zoltan prints its method at level 1
  parallel::ensure_started();
  const Teuchos::RCP<const Teuchos::Comm<int>> self =
      Teuchos::rcp(new Teuchos::MpiComm<int>(Teuchos::opaqueWrapper(MPI_COMM_SELF)));
  try {
    Zoltan2::PartitioningProblem<adapter_t> problem(&adapter, &params, self);
    problem.solve();
    const int* part = problem.getSolution().getPartListView();
    return std::vector<int>(part, part + n);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("Zoltan2 RCB partition: ") + e.what());
  }
}

}  // namespace peristat
