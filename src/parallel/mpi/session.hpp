// MPI's start and end. peristat runs in one process unless mpirun launched it: then main()
// starts MPI at once (Session) and every rank runs its part of the model. In a plain process
// MPI starts only when the Trilinos adapter asks for it (start_mpi(): a quiet singleton), and
// the adapter starts Tpetra on it. C++17-clean: the Trilinos adapter includes it.
#pragma once

namespace peristat::parallel {

/// True when this process was launched by mpirun (Open MPI's or another's environment).
bool launched_by_mpirun();

/// Starts MPI now if launched by mpirun; ends it (if started) when destroyed, after the
/// functions given to before_mpi_ends() (Tpetra's end). One per program, in main(),
/// outliving every distributed object.
class Session {
 public:
  Session();
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

/// Starts MPI when it is not running yet (a plain process: a singleton of one rank, quiet).
void start_mpi();
/// True once MPI runs.
bool started();
/// `end` runs before MPI ends (at the Session's end or at exit), the last given first.
void before_mpi_ends(void (*end)());
/// The ranks that share this machine's memory (1 before MPI starts).
int ranks_on_this_machine();
/// Ends every rank with `code` when more than one runs (an error that one rank meets alone
/// would leave the others waiting in a collective operation); returns otherwise.
void abort_if_distributed(int code);

}  // namespace peristat::parallel
