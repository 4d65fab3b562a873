// Counts heap allocations made by the current thread while a scope is active, so tests can assert
// "no allocation after construction" on the real-time path (a count, never a timer).
// Include it in exactly one .cpp of a test executable: it replaces the global operator new.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <new>

namespace swerve::testing {

inline thread_local long allocation_count = 0;
inline thread_local bool counting_allocations = false;

// Counts allocations made during its lifetime; `count()` reads them.
class AllocationCounter {
 public:
  AllocationCounter() : start_(allocation_count) { counting_allocations = true; }
  ~AllocationCounter() { counting_allocations = false; }
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;
  long count() const { return allocation_count - start_; }

 private:
  long start_;
};

}  // namespace swerve::testing

void* operator new(std::size_t size) {
  if (swerve::testing::counting_allocations) ++swerve::testing::allocation_count;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return ::operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
