// core/huge_pages.hpp: the per-bond arrays ask for transparent huge pages before they are
// first written (docs/performance.md, "Page faults and huge pages": 1.53 million -> 0.14 million page faults
// and 10-16 -> 4-7 s for `peristat check` of the 1000 x 1000 plate). The test of the backing
// itself is skipped, saying so, on kernels whose huge pages are disabled ("never").
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/huge_pages.hpp"
#include "core/types.hpp"

namespace peristat {
namespace {

/// The kernel's THP mode, the bracketed word of /sys/kernel/mm/transparent_hugepage/enabled
/// ("always", "madvise" or "never"), or "" where the file does not exist.
std::string thp_mode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  std::getline(in, line);
  const auto open = line.find('['), close = line.find(']');
  return open == std::string::npos || close == std::string::npos ? ""
                                                                 : line.substr(open + 1, close - open - 1);
}

/// AnonHugePages (kB) of the mapping of this process that holds `address` (/proc/self/smaps).
long huge_kb_of_mapping(const void* address) {
  const auto a = reinterpret_cast<std::uintptr_t>(address);
  std::ifstream in("/proc/self/smaps");
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    std::uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-') {
      inside = a >= lo && a < hi;
      continue;
    }
    if (inside && line.rfind("AnonHugePages:", 0) == 0) return std::stol(line.substr(14));
  }
  return -1;
}

TEST(HugePages, ReservedVectorKeepsItsContents) {
  // The advice changes how the memory is backed, never what it holds.
  std::vector<double> v;
  reserve_huge(v, std::size_t{8} << 20);  // 64 MB
  ASSERT_GE(v.capacity(), std::size_t{8} << 20);
  const double* const data = v.data();
  v.assign(std::size_t{8} << 20, 1.5);
  EXPECT_EQ(v.data(), data) << "assign() within the reserved capacity must not reallocate";
  double sum = 0.0;
  for (const double x : v) sum += x;
  EXPECT_EQ(sum, 1.5 * double(std::size_t{8} << 20));
}

// zero_huge_on_threads() writes every byte itself (the vector's resize leaves them unwritten):
// on the heap block a freed array of ones leaves (64 KB, below glibc's default mmap threshold
// of 128 KB; without the zeroing all 4000 elements stay ones) and on a fresh mapping whose last
// 2 MB chunk is partial, every element is zero.
TEST(HugePages, ZeroOnThreadsZeroesEveryElement) {
  for (const std::size_t n : {std::size_t{4000}, (std::size_t{3} << 21) / sizeof(Vec2) + 5}) {
    SCOPED_TRACE(n);
    { UnwrittenVector<Vec2> ones(n, Vec2(1.0, 1.0)); }
    UnwrittenVector<Vec2> v;
    zero_huge_on_threads(v, n);
    ASSERT_EQ(v.size(), n);
    std::size_t nonzero = 0;
    for (const Vec2& x : v) nonzero += x.x() != 0.0 || x.y() != 0.0;
    EXPECT_EQ(nonzero, 0u);
  }
}

TEST(HugePages, SmallNullAndUnalignedRangesAreLeftAlone) {
  // Below 4 MB, or for no memory, nothing is advised (and nothing may fail).
  advise_huge_pages(nullptr, std::size_t{1} << 30);
  std::vector<char> small(1000, 'x');
  advise_huge_pages(small.data(), small.size());
  reserve_huge(small, 2000);
  EXPECT_EQ(small.size(), 1000u);
  EXPECT_EQ(small[999], 'x');
}

TEST(HugePages, ShrinkReleasesOnlyALargeSlack) {
  std::vector<int> v;
  reserve_huge(v, 1600);
  v.assign(1590, 7);  // slack 10 <= 1590 / 16: kept, no copy
  const int* const data = v.data();
  shrink_huge(v);
  EXPECT_EQ(v.data(), data);
  v.resize(1000);  // slack 600 > 1000 / 16: released, the contents kept
  shrink_huge(v);
  EXPECT_EQ(v.capacity(), 1000u);
  EXPECT_EQ(v.size(), 1000u);
  EXPECT_EQ(v.front(), 7);
  EXPECT_EQ(v.back(), 7);
}

TEST(HugePages, A64MBArrayIsBackedByHugePagesWhereTheKernelOffersThem) {
  const std::string mode = thp_mode();
  if (mode != "always" && mode != "madvise")
    GTEST_SKIP() << "transparent huge pages are '" << mode
                 << "' on this kernel: no huge page can be asked for";
  std::vector<double> v;
  reserve_huge(v, std::size_t{8} << 20);
  v.assign(std::size_t{8} << 20, 2.0);
  // At least one 2 MB page of the 64 MB: the kernel falls back to small pages only where it
  // finds no free huge page, which a machine with memory to spare (as this project's) does.
  EXPECT_GE(huge_kb_of_mapping(v.data() + (std::size_t{4} << 20)), 2048) << "mode " << mode;
}

}  // namespace
}  // namespace peristat
