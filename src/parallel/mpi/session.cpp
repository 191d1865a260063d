#include "parallel/mpi/session.hpp"

#include <cstdlib>
#include <vector>

#include <mpi.h>

namespace peristat::parallel {

namespace {

bool g_we_started = false;         // MPI_Init was ours: MPI_Finalize is ours too
std::vector<void (*)()> g_ends;    // before_mpi_ends(), in the order given

void end_mpi() {
  while (!g_ends.empty()) {
    void (*end)() = g_ends.back();
    g_ends.pop_back();
    end();
  }
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (g_we_started && !finalized) MPI_Finalize();
  g_we_started = false;
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

void start() {
  if (started()) return;
  if (!launched_by_mpirun()) quiet_singleton();
  // MPI sees no arguments: the program's own options are not MPI's.
  MPI_Init(nullptr, nullptr);
  g_we_started = true;
  std::atexit(end_mpi);  // also when MPI started lazily; a no-op after the Session's end
}

}  // namespace

bool launched_by_mpirun() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr || std::getenv("PMI_SIZE") != nullptr ||
         std::getenv("PMIX_RANK") != nullptr;
}

bool started() {
  int initialized = 0;
  MPI_Initialized(&initialized);
  return initialized != 0;
}

Session::Session() {
  if (launched_by_mpirun()) start();
}

Session::~Session() { end_mpi(); }

void start_mpi() { start(); }

void before_mpi_ends(void (*end)()) { g_ends.push_back(end); }

int ranks_on_this_machine() {
  if (!started()) return 1;
  MPI_Comm shared;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &shared);
  int n = 1;
  MPI_Comm_size(shared, &n);
  MPI_Comm_free(&shared);
  return n;
}

void abort_if_distributed(int code) {
  if (!started()) return;
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size > 1) MPI_Abort(MPI_COMM_WORLD, code);
}

}  // namespace peristat::parallel
