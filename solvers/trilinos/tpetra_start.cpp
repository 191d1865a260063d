#include "solvers/trilinos/tpetra_start.hpp"

#include <Teuchos_CommHelpers.hpp>
#include <Tpetra_Core.hpp>

#include "parallel/mpi/session.hpp"

namespace peristat::parallel {

namespace {

int g_argc = 0;  // Kokkos sees no arguments (ensure_started)
char** g_argv = nullptr;

void finalize_tpetra() {
  if (Tpetra::isInitialized()) Tpetra::finalize();
}

}  // namespace

void ensure_started() {
  if (Tpetra::isInitialized()) return;
  // MPI first (src/parallel/mpi), then Tpetra on it; Tpetra ends before MPI does. Kokkos sees
  // no arguments: Kokkos::initialize parses the command line and aborts on peristat's own
  // `--threads 1` (it wants its `--threads=N`), or prints its help for `--help`.
  start_mpi();
  Tpetra::initialize(&g_argc, &g_argv);
  before_mpi_ends(finalize_tpetra);
}

double max_over_ranks(double value) {
  ensure_started();
  double result = value;
  Teuchos::reduceAll(*Tpetra::getDefaultComm(), Teuchos::REDUCE_MAX, value, Teuchos::outArg(result));
  return result;
}

}  // namespace peristat::parallel
