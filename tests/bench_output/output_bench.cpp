// peristat_bench_output: how a distributed run should write its results (issue 16, item 3),
// measured, not a test. Run under mpirun:
//   mpirun -n P peristat_bench_output [--particles N] [--steps S] [--dir DIR]
// A square lattice of N particles (n x n, numbered row by row like a body of the scene) is
// split into P rectangles by recursive bisection across the longer side, as Zoltan2's RCB
// splits a plate (solver.belos.partition: rcb): a rank's particles are then n/py runs of
// n/px consecutive numbers, not one block. Each step writes the heaviest layout a serial run
// writes per step: displacement (N x 2), damage (N), contact_force (N x 2), that is
// 40 bytes per particle, into /steps/NNNNNN of one file, opening and closing the file per
// step as the results writer does (a killed run keeps every step before the kill).
//   gather:   every rank sends its values to rank 0 (MPI_Gatherv), rank 0 puts them in
//             lattice order and writes with the serial driver (what peristat does).
//   parallel: every rank writes its own rectangle into the same datasets through MPI-IO
//             (H5Pset_fapl_mpio, one regular hyperslab per rank, collective transfer).
// Every value is a function of its particle and step; rank 0 reads both files back and
// checks every value, so that a time is never one of a wrong write. One line per method:
// median and best seconds per step over the steps, and bytes per step.
//
// It links Debian's MPI build of HDF5 (libhdf5-openmpi-dev) and nothing of peristat, so that
// the serial HDF5 of peristat's io library never meets the MPI one in a translation unit.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <hdf5.h>
#include <mpi.h>

namespace {

struct Rect {
  long x0, x1, y0, y1;  // [x0, x1) x [y0, y1) in lattice columns and rows
  long count() const { return (x1 - x0) * (y1 - y0); }
};

/// P parts of nearly equal count: cut the longer side, the parts' counts in proportion.
void bisect(const Rect& r, int parts, std::vector<Rect>& out) {
  if (parts == 1) {
    out.push_back(r);
    return;
  }
  const int left = parts / 2;
  Rect a = r, b = r;
  if (r.x1 - r.x0 >= r.y1 - r.y0) {
    const long cut = r.x0 + (r.x1 - r.x0) * left / parts;
    a.x1 = cut;
    b.x0 = cut;
  } else {
    const long cut = r.y0 + (r.y1 - r.y0) * left / parts;
    a.y1 = cut;
    b.y0 = cut;
  }
  bisect(a, left, out);
  bisect(b, parts - left, out);
}

/// The value written for component c (0..4) of particle id at step s: exact in double.
double value(long id, int c, int s) {
  return double(id) * 8.0 + c + 0.5 * s;
}

void check(herr_t status, const char* what) {
  if (status < 0) {
    std::fprintf(stderr, "peristat_bench_output: HDF5 failed to %s\n", what);
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
}

hid_t check_id(hid_t id, const char* what) {
  check(id < 0 ? -1 : 0, what);
  return id;
}

std::string group_name(int s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "/steps/%06d", s);
  return buf;
}

struct Field {
  const char* name;
  int columns;  // 1 or 2
  int first;    // first component of the five
};
const Field kFields[] = {{"displacement", 2, 0}, {"damage", 1, 2}, {"contact_force", 2, 3}};

/// The file with /steps, through `fapl`.
void create_file(const std::string& path, hid_t fapl) {
  hid_t file = check_id(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl), "create the file");
  hid_t steps = check_id(H5Gcreate2(file, "steps", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "create /steps");
  check(H5Gclose(steps), "close /steps");
  check(H5Fclose(file), "close the file");
}

/// Creates the step's datasets of N rows in `group` and writes them: each rank its rectangle
/// (`mine`, with `local` its values in rank order, five per particle), or rank 0 everything
/// (`mine` = the whole lattice, `local` in lattice order).
void write_fields(hid_t group, long n, const Rect& mine, const std::vector<double>& local, hid_t dxpl,
                  std::vector<double>& column) {
  const long count = mine.count();
  for (const Field& f : kFields) {
    hsize_t dims[2] = {hsize_t(n * n), hsize_t(f.columns)};
    hid_t file_space = check_id(H5Screate_simple(f.columns == 2 ? 2 : 1, dims, nullptr), "create a space");
    hid_t dset =
        check_id(H5Dcreate2(group, f.name, H5T_IEEE_F64LE, file_space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                 "create a dataset");
    // The rectangle: rows y0..y1 of the lattice, each a run of x1 - x0 particles.
    hsize_t start[2] = {hsize_t(mine.y0 * n + mine.x0), 0};
    hsize_t stride[2] = {hsize_t(n), 1};
    hsize_t blocks[2] = {hsize_t(mine.y1 - mine.y0), 1};
    hsize_t block[2] = {hsize_t(mine.x1 - mine.x0), hsize_t(f.columns)};
    check(H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start, stride, blocks, block),
          "select a hyperslab");
    column.resize(std::size_t(count) * f.columns);
    for (long k = 0; k < count; ++k)
      for (int c = 0; c < f.columns; ++c)
        column[std::size_t(k * f.columns + c)] = local[std::size_t(k * 5 + f.first + c)];
    hsize_t mem_dims[2] = {hsize_t(count), hsize_t(f.columns)};
    hid_t mem_space = check_id(H5Screate_simple(f.columns == 2 ? 2 : 1, mem_dims, nullptr), "create a space");
    check(H5Dwrite(dset, H5T_NATIVE_DOUBLE, mem_space, file_space, dxpl, column.data()), "write a dataset");
    check(H5Sclose(mem_space), "close a space");
    check(H5Sclose(file_space), "close a space");
    check(H5Dclose(dset), "close a dataset");
  }
}

/// Rank 0: every value of the file at every step is value(id, c, s).
long verify(const std::string& path, long n, int steps) {
  long wrong = 0;
  hid_t file = check_id(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "open the file to check it");
  std::vector<double> buf;
  for (int s = 1; s <= steps; ++s) {
    for (const Field& f : kFields) {
      const std::string name = group_name(s) + "/" + f.name;
      hid_t dset = check_id(H5Dopen2(file, name.c_str(), H5P_DEFAULT), "open a dataset to check it");
      buf.assign(std::size_t(n * n * f.columns), -1.0);
      check(H5Dread(dset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()), "read a dataset");
      for (long id = 0; id < n * n; ++id)
        for (int c = 0; c < f.columns; ++c)
          if (buf[std::size_t(id * f.columns + c)] != value(id, f.first + c, s)) ++wrong;
      check(H5Dclose(dset), "close a dataset");
    }
  }
  check(H5Fclose(file), "close the file");
  return wrong;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  long particles = 1000000;
  int steps = 5;
  std::string dir = "/tmp";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--particles") == 0)
      particles = std::atol(argv[i + 1]);
    else if (std::strcmp(argv[i], "--steps") == 0)
      steps = std::atoi(argv[i + 1]);
    else if (std::strcmp(argv[i], "--dir") == 0)
      dir = argv[i + 1];
    else {
      if (rank == 0) std::fprintf(stderr, "peristat_bench_output: unknown option %s\n", argv[i]);
      MPI_Finalize();
      return 2;
    }
  }
  if (argc % 2 == 0 || particles < 4 || steps < 1) {
    if (rank == 0)
      std::fprintf(stderr,
                   "usage: mpirun -n P peristat_bench_output [--particles N] [--steps S] [--dir DIR]\n");
    MPI_Finalize();
    return 2;
  }
  const long n = std::lround(std::sqrt(double(particles)));
  std::vector<Rect> parts;
  bisect(Rect{0, n, 0, n}, ranks, parts);
  const Rect mine = parts[std::size_t(rank)];
  const long count = mine.count();

  std::vector<double> local(std::size_t(count) * 5), column;
  auto fill = [&](int s) {
    long k = 0;
    for (long y = mine.y0; y < mine.y1; ++y)
      for (long x = mine.x0; x < mine.x1; ++x, ++k)
        for (int c = 0; c < 5; ++c) local[std::size_t(k * 5 + c)] = value(y * n + x, c, s);
  };
  const double bytes_per_step = 40.0 * double(n * n);

  // gather: rank 0 receives every rank's values and writes alone.
  const std::string gather_path = dir + "/peristat_bench_output_gather.h5";
  std::vector<double> gathered, ordered;
  std::vector<int> counts(static_cast<std::size_t>(ranks)), displs(static_cast<std::size_t>(ranks));
  for (int p = 0; p < ranks; ++p) {
    counts[std::size_t(p)] = int(parts[std::size_t(p)].count() * 5);
    displs[std::size_t(p)] = p == 0 ? 0 : displs[std::size_t(p - 1)] + counts[std::size_t(p - 1)];
  }
  if (rank == 0) {
    create_file(gather_path, H5P_DEFAULT);
    gathered.resize(std::size_t(n * n * 5));
    ordered.resize(std::size_t(n * n * 5));
  }
  std::vector<double> t_gather, t_gather_comm;
  for (int s = 1; s <= steps; ++s) {
    fill(s);
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    MPI_Gatherv(local.data(), int(local.size()), MPI_DOUBLE, gathered.data(), counts.data(), displs.data(),
                MPI_DOUBLE, 0, MPI_COMM_WORLD);
    const double t1 = MPI_Wtime();
    if (rank == 0) {
      for (int p = 0; p < ranks; ++p) {  // rank order -> lattice order
        const Rect& r = parts[std::size_t(p)];
        long k = displs[std::size_t(p)] / 5;
        for (long y = r.y0; y < r.y1; ++y)
          for (long x = r.x0; x < r.x1; ++x, ++k)
            std::memcpy(&ordered[std::size_t((y * n + x) * 5)], &gathered[std::size_t(k * 5)],
                        5 * sizeof(double));
      }
      hid_t file = check_id(H5Fopen(gather_path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), "open the file");
      hid_t group = check_id(H5Gcreate2(file, group_name(s).c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                             "create a step group");
      write_fields(group, n, Rect{0, n, 0, n}, ordered, H5P_DEFAULT, column);
      check(H5Gclose(group), "close a step group");
      check(H5Fclose(file), "close the file");
    }
    MPI_Barrier(MPI_COMM_WORLD);
    t_gather.push_back(MPI_Wtime() - t0);
    t_gather_comm.push_back(t1 - t0);
  }

  // parallel: every rank writes its rectangle through MPI-IO.
  const std::string parallel_path = dir + "/peristat_bench_output_parallel.h5";
  hid_t fapl = check_id(H5Pcreate(H5P_FILE_ACCESS), "create a file access list");
  check(H5Pset_fapl_mpio(fapl, MPI_COMM_WORLD, MPI_INFO_NULL), "set the MPI-IO driver");
  hid_t dxpl = check_id(H5Pcreate(H5P_DATASET_XFER), "create a transfer list");
  check(H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE), "set collective transfer");
  create_file(parallel_path, fapl);
  std::vector<double> t_parallel;
  for (int s = 1; s <= steps; ++s) {
    fill(s);
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    hid_t file = check_id(H5Fopen(parallel_path.c_str(), H5F_ACC_RDWR, fapl), "open the file");
    hid_t group = check_id(H5Gcreate2(file, group_name(s).c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                           "create a step group");
    write_fields(group, n, mine, local, dxpl, column);
    check(H5Gclose(group), "close a step group");
    check(H5Fclose(file), "close the file");
    MPI_Barrier(MPI_COMM_WORLD);
    t_parallel.push_back(MPI_Wtime() - t0);
  }
  check(H5Pclose(dxpl), "close a transfer list");
  check(H5Pclose(fapl), "close a file access list");

  int status = 0;
  if (rank == 0) {
    const long wrong_gather = verify(gather_path, n, steps);
    const long wrong_parallel = verify(parallel_path, n, steps);
    long runs_max = 0;
    for (const Rect& r : parts) runs_max = std::max(runs_max, r.y1 - r.y0);
    const auto line = [&](const char* method, const std::vector<double>& t, long wrong) {
      std::printf(
          "method=%s ranks=%d particles=%ld steps=%d bytes_per_step=%.0f runs_per_rank_max=%ld "
          "seconds_per_step_median=%.4f seconds_per_step_best=%.4f MB_per_s=%.0f wrong_values=%ld\n",
          method, ranks, n * n, steps, bytes_per_step, runs_max, median(t),
          *std::min_element(t.begin(), t.end()), bytes_per_step / median(t) / 1e6, wrong);
    };
    line("gather", t_gather, wrong_gather);
    std::printf("method=gather_communication_only ranks=%d seconds_per_step_median=%.4f\n", ranks,
                median(t_gather_comm));
    line("parallel", t_parallel, wrong_parallel);
    std::fflush(stdout);
    std::remove(gather_path.c_str());
    std::remove(parallel_path.c_str());
    if (wrong_gather != 0 || wrong_parallel != 0) status = 1;
  }
  MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
  MPI_Finalize();
  return status;
}
