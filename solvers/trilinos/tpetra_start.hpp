// Tpetra's start on the MPI that src/parallel/mpi starts (a quiet singleton in a plain process,
// MPI_COMM_WORLD under mpirun), and its end before MPI's. The adapter's own MPI: nothing
// outside solvers/trilinos calls it; the program reaches the other ranks through `Ranks`.
#pragma once

namespace peristat::parallel {

/// Starts MPI and Tpetra on it when they are not running yet; Tpetra ends before MPI does.
void ensure_started();
/// The largest value over MPI_COMM_WORLD's ranks (collective; Tpetra started).
double max_over_ranks(double value);

}  // namespace peristat::parallel
