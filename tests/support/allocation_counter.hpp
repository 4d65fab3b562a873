// Counts heap allocations made by the current thread while a scope is active, so tests can assert
// "no allocation after construction" on the real-time path (a count, never a timer). It hooks
// malloc itself (Eigen allocates through malloc, not operator new), forwarding to glibc.
// Include it in exactly one .cpp of a test executable. Under AddressSanitizer or ThreadSanitizer,
// which own malloc, counting is unavailable: tests call `AllocationCounter::available()` and
// GTEST_SKIP.
#pragma once

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SWERVE_SANITIZER_OWNS_MALLOC 1
#endif

#include <cstddef>
#include <cstdlib>

namespace swerve::testing {

inline thread_local long allocation_count = 0;
inline thread_local bool counting_allocations = false;

class AllocationCounter {
 public:
  AllocationCounter() : start_(allocation_count) { counting_allocations = true; }
  ~AllocationCounter() { counting_allocations = false; }
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;
  long count() const { return allocation_count - start_; }
  static bool available() {
#if defined(SWERVE_SANITIZER_OWNS_MALLOC)
    return false;
#else
    return true;
#endif
  }

 private:
  long start_;
};

}  // namespace swerve::testing

#if !defined(SWERVE_SANITIZER_OWNS_MALLOC)
extern "C" {
void* __libc_malloc(std::size_t size) noexcept;
void* __libc_calloc(std::size_t count, std::size_t size) noexcept;
void* __libc_realloc(void* pointer, std::size_t size) noexcept;
void* __libc_memalign(std::size_t alignment, std::size_t size) noexcept;

inline void swerve_count_allocation() noexcept {
  if (swerve::testing::counting_allocations) ++swerve::testing::allocation_count;
}
void* malloc(std::size_t size) noexcept {
  swerve_count_allocation();
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) noexcept {
  swerve_count_allocation();
  return __libc_calloc(count, size);
}
void* realloc(void* pointer, std::size_t size) noexcept {
  swerve_count_allocation();
  return __libc_realloc(pointer, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  swerve_count_allocation();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) noexcept {
  swerve_count_allocation();
  *out = __libc_memalign(alignment, size);
  return *out ? 0 : 12;  // ENOMEM
}
}
#endif
