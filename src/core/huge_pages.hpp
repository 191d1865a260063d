#pragma once
// Transparent huge pages for the largest arrays (the bonds and their per-bond state).
//
// First touching fresh memory costs more than computing on it on the project's machine kind:
// `peristat check` of the 1000 x 1000 plate spent 7-13 of its 10-16 s in the kernel, faulting
// in 4.8 GB one 4 KB page at a time (1.53 million faults; 0.14 million with these helpers:
// docs/performance.md, "Page faults and huge pages").
// Where the kernel grants huge pages only on request (/sys/kernel/mm/transparent_hugepage/
// enabled = madvise, Debian's default), an array asks for them before it is first written.
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace peristat {

/// Blocks of 1 MiB and more come from the kernel and go back to it when freed (glibc's
/// mmap threshold, fixed). Left to itself glibc raises the threshold after the first large
/// free, up to 32 MiB, and the arrays freed later stay in the process as holes in its heap:
/// the 700 x 700 plate on four ranks peaked at 1.03-1.06 GB a rank, 0.94-0.98 GB with the
/// threshold fixed (docs/guide/distributed.md, the 700 x 700 plate under "Measured"). Call
/// once, at the program's start; a no-op outside glibc.
void return_large_blocks() noexcept;

/// Runs estimated at this many bytes or more start glibc's malloc on huge pages
/// (start_malloc_on_huge_pages). Measured (docs/performance.md, "Page faults and huge pages"):
/// the V-cycle's set-up of the 1000 x 1000 plate (4.7 GB estimated) takes 1.5-4 s less, of the
/// 2000 x 2000 plate 6 s less; the 300 x 300 plate (0.49 GB), case 4.4 at dx = 0.01 m and the
/// running crack gain nothing, and case 4.3 loses about 0.03 s of 0.6 s to the tunable and
/// 0.05 s to the second start.
inline constexpr double kHugePageMallocBytes = 1e9;

/// glibc's malloc asks for transparent huge pages for the blocks it maps from the kernel only
/// with its tunable glibc.malloc.hugetlb=1, which it reads from the environment at the
/// program's start. For a run whose estimated memory is at least kHugePageMallocBytes this
/// adds the tunable to GLIBC_TUNABLES and executes the program again with the same arguments
/// (/proc/self/cmdline; the same process), unless the environment names the tunable already
/// (a user's choice: 0 declines it), the kernel offers no huge pages ("never"), a tool is
/// preloaded (valgrind, heaptrack: LD_PRELOAD) or the build is sanitized. Call before anything
/// is printed and before MPI starts; returns when it does not execute again.
void start_malloc_on_huge_pages(double estimated_bytes);

/// What this process's malloc was started with: "on (...)" with glibc.malloc.hugetlb=1 in
/// GLIBC_TUNABLES, else "off (why)".
std::string malloc_huge_pages_state();

/// The kernel's transparent huge page mode (the bracketed word of
/// /sys/kernel/mm/transparent_hugepage/enabled), or "" where there is none.
std::string transparent_huge_page_mode();

/// Advises the kernel to back [data, data + bytes) with huge pages: the 2 MB-aligned part
/// of it, for ranges of at least 4 MB; a no-op where the kernel does not support the advice.
void advise_huge_pages(void* data, std::size_t bytes) noexcept;

/// An allocator whose construct() default-initialises: a vector resized with it leaves
/// trivially constructible elements unwritten, so that whoever writes them first faults
/// their pages in (zero_huge_on_threads()).
template <class T>
struct UnwrittenAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = UnwrittenAllocator<U>;
  };
  UnwrittenAllocator() noexcept = default;
  template <class U>
  UnwrittenAllocator(const UnwrittenAllocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
template <class T>
using UnwrittenVector = std::vector<T, UnwrittenAllocator<T>>;

/// v.reserve(n), then the advice on its storage: call before v is first filled.
template <class T, class A>
void reserve_huge(std::vector<T, A>& v, std::size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}

/// v.assign(n, value) into storage reserved by reserve_huge(): the per-bond arrays' form.
template <class T>
void assign_huge(std::vector<T>& v, std::size_t n, const T& value) {
  reserve_huge(v, n);
  v.assign(n, value);
}

/// v resized to n zero elements (all bytes zero) on storage reserved by reserve_huge(), the
/// zeros written by this program's threads, each its share: the kernel clears a fresh page in
/// the thread that first touches it (docs/performance.md, "Page faults and huge pages"). For
/// the per-bond factors, allocated again after each preconditioner set-up.
template <class T>
void zero_huge_on_threads(UnwrittenVector<T>& v, std::size_t n) {
  // Plain numbers (Eigen's fixed-size vectors, std::array): all-zero bytes are a zero element.
  static_assert(std::is_standard_layout_v<T> && std::is_trivially_destructible_v<T>,
                "a plain numeric element");
  reserve_huge(v, n);
  v.resize(n);  // unwritten
  auto* bytes = reinterpret_cast<unsigned char*>(v.data());
  const std::size_t total = n * sizeof(T), chunk = std::size_t{1} << 21;  // a huge page
  const auto chunks = static_cast<long long>((total + chunk - 1) / chunk);
#pragma omp parallel for schedule(static)
  for (long long c = 0; c < chunks; ++c) {
    const std::size_t begin = static_cast<std::size_t>(c) * chunk;
    std::memset(bytes + begin, 0, std::min(chunk, total - begin));
  }
}

/// Releases a vector's unused capacity when it is more than a sixteenth of its size, into
/// storage advised as by reserve_huge(). A smaller slack is kept: capacity never written
/// takes no memory, and copying the array would touch every page again.
template <class T>
void shrink_huge(std::vector<T>& v) {
  if (v.capacity() - v.size() <= v.size() / 16) return;
  std::vector<T> fitted;
  reserve_huge(fitted, v.size());
  fitted.assign(v.begin(), v.end());
  v.swap(fitted);
}

}  // namespace peristat
