// Counts heap allocations, to check that steady-state work allocates nothing. malloc itself is
// wrapped (glibc), so operator new and Eigen's heap allocations (which go through malloc) both
// count; posix_memalign and aligned_alloc are not wrapped. Include in exactly one source file of
// a test program: it defines malloc, calloc and realloc for the whole program.
#pragma once

#include <atomic>
#include <cstddef>

#ifdef __GLIBC__
#define FEM_CLOTH_COUNT_ALLOCATIONS 1
namespace fem_cloth::test {
inline std::atomic<long> allocationCount{0};
}  // namespace fem_cloth::test
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* malloc(std::size_t size) {
  fem_cloth::test::allocationCount.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  fem_cloth::test::allocationCount.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(count, size);
}
void* realloc(void* p, std::size_t size) {
  fem_cloth::test::allocationCount.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, size);
}
}
#endif
