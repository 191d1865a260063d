#include "solvers/trilinos/parallel.hpp"

#include <cstdlib>

#include <mpi.h>

#include <Tpetra_Core.hpp>

namespace peristat::parallel {

namespace {

int g_argc = 0;  // MPI_Init of a plain process sees no arguments
char** g_argv = nullptr;

void finalize_at_exit() {
  if (Tpetra::isInitialized()) Tpetra::finalize();
}

/// A process that mpirun did not start is alone: MPI serves MueLu and Belos inside it only.
/// Open MPI's defaults would still start a singleton orted and probe UCX, 0.27 s of every
/// such run (case 4.3: model built in 0.31 s, 0.05 s with these); the process needs none of
/// it. The user's own settings win (no overwrite).
void quiet_singleton() {
  setenv("OMPI_MCA_ess_singleton_isolated", "1", 0);
  setenv("OMPI_MCA_pml", "ob1", 0);
  setenv("OMPI_MCA_osc", "^ucx", 0);
  setenv("OMPI_MCA_btl", "self", 0);
}

void start(int* argc, char*** argv) {
  if (Tpetra::isInitialized()) return;
  if (!launched_by_mpirun()) quiet_singleton();
  Tpetra::initialize(argc, argv);
  // After main() returns (every solver is gone by then), also when MPI started lazily.
  std::atexit(finalize_at_exit);
}

}  // namespace

bool launched_by_mpirun() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr || std::getenv("PMI_SIZE") != nullptr ||
         std::getenv("PMIX_RANK") != nullptr;
}

Session::Session(int* argc, char*** argv) {
  if (launched_by_mpirun()) start(argc, argv);
}

Session::~Session() { finalize_at_exit(); }

void ensure_started() { start(&g_argc, &g_argv); }

int rank() { return Tpetra::isInitialized() ? Tpetra::getDefaultComm()->getRank() : 0; }

int size() { return Tpetra::isInitialized() ? Tpetra::getDefaultComm()->getSize() : 1; }

int ranks_on_this_machine() {
  if (!Tpetra::isInitialized()) return 1;
  MPI_Comm shared;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &shared);
  int n = 1;
  MPI_Comm_size(shared, &n);
  MPI_Comm_free(&shared);
  return n;
}

double max_over_ranks(double value) {
  if (size() <= 1) return value;
  double result = value;
  MPI_Allreduce(&value, &result, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return result;
}

long long sum_over_ranks(long long value) {
  if (size() <= 1) return value;
  long long result = value;
  MPI_Allreduce(&value, &result, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  return result;
}

void abort_if_distributed(int code) {
  if (size() > 1) MPI_Abort(MPI_COMM_WORLD, code);
}

}  // namespace peristat::parallel
