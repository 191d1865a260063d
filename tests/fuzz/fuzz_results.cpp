// Fuzz target: the results reader behind `peristat probe` and `peristat compare`
// (src/io/results.hpp, src/io/compare.hpp).
//
// Input: the bytes of a results file. They are written to one temporary file per process
// and read as probe and compare read them: open, every field of the first and last step,
// a line probe across the particles, the first step compared with the last, and the
// particle table checked against a fixed valid file (results_reference.h5 beside this one).
//
// Expected outcome for a bad file: InputError (core/error.hpp), which the reader documents
// for every failure to read a file, HDF5's included. Anything else is a finding: another
// exception type, a crash, a sanitizer report, a leak, a hang, or an HDF5 object (file,
// group, dataset, attribute, ...) left open after the input (checked here; a leaked HDF5
// handle is reachable from HDF5's tables, so LeakSanitizer would not see it).
// Leaks inside HDF5 itself (its error paths on damaged files) are suppressed by
// lsan_suppressions.txt; docs/verification.md, "Fuzzing", records them.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>

#include <hdf5.h>

#include "core/error.hpp"
#include "io/compare.hpp"
#include "io/results.hpp"

#ifndef PERISTAT_FUZZ_REFERENCE
#error "PERISTAT_FUZZ_REFERENCE must name a valid results file (tests/fuzz/CMakeLists.txt)"
#endif

namespace {

/// One file per process, removed at exit (the string is never destroyed: the handler needs it).
const std::string& scratch_path() {
  static const std::string* const path = [] {
    const std::string name = "peristat-fuzz-results-" + std::to_string(::getpid()) + ".h5";
    const auto* p = new std::string((std::filesystem::temp_directory_path() / name).string());
    std::atexit([] { std::remove(scratch_path().c_str()); });
    return p;
  }();
  return *path;
}

const peristat::ResultsReader& reference() {
  static const peristat::ResultsReader reader(PERISTAT_FUZZ_REFERENCE);
  return reader;
}

void write_scratch(const std::uint8_t* data, std::size_t size) {
  std::FILE* out = std::fopen(scratch_path().c_str(), "wb");
  if (out == nullptr || (size > 0 && std::fwrite(data, 1, size, out) != size) || std::fclose(out) != 0) {
    std::fprintf(stderr, "fuzz_results: cannot write '%s'\n", scratch_path().c_str());
    std::abort();
  }
}

/// Every field of one step, as probe and compare read them.
void read_step(const peristat::ResultsReader& results, int step) {
  (void)results.load_factor(step);
  (void)results.displacement(step);
  try {
    (void)results.damage(step);
  } catch (const peristat::InputError&) {
    // a run without failure has no damage
  }
}

void read(const std::string& path) {
  const peristat::ResultsReader results(path);
  try {
    require_same_particles(results, "fuzz.h5", reference(), "reference.h5");
  } catch (const peristat::InputError&) {
    // most inputs hold other particles; the rest is read all the same
  }
  if (results.steps().empty()) return;
  const int first = results.steps().front();
  const int last = results.steps().back();
  read_step(results, first);
  read_step(results, last);
  const auto& position = results.particles().position;
  if (!position.empty()) {
    (void)peristat::probe_line(results, last, position.front(), position.back(), 17);
  }
  (void)peristat::compare_results(results, "fuzz.h5", first, results, "fuzz.h5", last);
}

/// HDF5's default free-list limits are too small to keep the metadata cache that every
/// H5Fopen callocs: it is freed and its pages faulted in again at each open (perf). With no
/// limit it is reused: 1.9 instead of 5.5 ms of CPU per valid input under ASan.
bool keep_hdf5_free_lists() {
  return H5set_free_list_limits(-1, -1, -1, -1, -1, -1) >= 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool fast = keep_hdf5_free_lists();
  (void)fast;
  (void)reference();  // opened before the first input, so that its failure is not blamed on one
  write_scratch(data, size);
  try {
    read(scratch_path());
  } catch (const peristat::InputError&) {
    // the documented outcome for a bad file
  }
  const ssize_t open_objects = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL);
  if (open_objects != 0) {
    std::fprintf(stderr, "fuzz_results: %zd HDF5 objects left open after the input\n", open_objects);
    std::abort();
  }
  return 0;
}
