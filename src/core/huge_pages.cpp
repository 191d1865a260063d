#include "core/huge_pages.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <sys/mman.h>
#include <unistd.h>
#include <vector>
#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace peristat {

void return_large_blocks() noexcept {
#ifdef __GLIBC__
  (void)mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
}

namespace {
constexpr const char* kTunable = "glibc.malloc.hugetlb";

bool sanitized() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  return true;
#else
  return false;
#endif
}
}  // namespace

std::string transparent_huge_page_mode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  if (!std::getline(in, line)) return {};
  const auto open = line.find('['), close = line.find(']');
  return open != std::string::npos && close > open ? line.substr(open + 1, close - open - 1) : std::string{};
}

namespace {
constexpr const char* kDefaultState =
    "off (peristat starts it on huge pages for runs estimated at 1 GB or more, not under mpirun)";
}  // namespace

std::string malloc_huge_pages_state() {
#ifdef __GLIBC__
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  const std::string t = tunables ? tunables : "";
  if (t.find(std::string(kTunable) + "=1") != std::string::npos) return "on (GLIBC_TUNABLES " + t + ")";
  if (t.find(kTunable) != std::string::npos) return "off (GLIBC_TUNABLES " + t + ")";
  const std::string mode = transparent_huge_page_mode();
  if (mode.empty() || mode == "never") return "off (the kernel offers no transparent huge pages)";
  if (sanitized()) return "off (a sanitizer's allocator)";
  if (const char* preload = std::getenv("LD_PRELOAD"); preload && *preload) return "off (LD_PRELOAD is set)";
  return kDefaultState;
#else
  return "off (not glibc)";
#endif
}

namespace {
/// This process's arguments as the kernel holds them (/proc/self/cmdline, NUL-separated).
std::vector<std::string> own_arguments() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::vector<std::string> args;
  std::string arg;
  while (std::getline(in, arg, '\0')) args.push_back(arg);
  return args;
}
}  // namespace

void start_malloc_on_huge_pages(double estimated_bytes) {
#ifdef __GLIBC__
  // Only where nothing else decided: the tunable named already (the user's choice), no huge
  // pages, a sanitizer, a preloaded tool.
  if (estimated_bytes < kHugePageMallocBytes || malloc_huge_pages_state() != kDefaultState) return;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  std::vector<std::string> args = own_arguments();
  if (args.empty()) return;
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const bool had = tunables != nullptr;
  const std::string old = had ? tunables : "";
  const std::string value = (old.empty() ? std::string() : old + ":") + kTunable + "=1";
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  std::fflush(nullptr);
  execv("/proc/self/exe", argv.data());
  // Not executed (no /proc): go on as started, with the environment as it was.
  if (had)
    setenv("GLIBC_TUNABLES", old.c_str(), 1);
  else
    unsetenv("GLIBC_TUNABLES");
#else
  (void)estimated_bytes;
#endif
}

void advise_huge_pages(void* data, std::size_t bytes) noexcept {
#ifdef MADV_HUGEPAGE
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  if (data == nullptr || bytes < 2 * kHuge) return;
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1), last = (begin + bytes) & ~(kHuge - 1);
  // Advice only: a kernel without transparent huge pages answers EINVAL and nothing changes.
  if (last > first) (void)madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
#else
  (void)data;
  (void)bytes;
#endif
}

}  // namespace peristat
