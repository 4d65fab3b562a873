// SWERVE_DCHECK: internal invariants, checked in Debug and test builds (SWERVE_ENABLE_DCHECKS)
// and compiled out in Release so the real-time path pays nothing for them.
#pragma once

#include <cstdio>
#include <cstdlib>

#if defined(SWERVE_ENABLE_DCHECKS) || !defined(NDEBUG)
#define SWERVE_DCHECK(condition)                                                               \
  do {                                                                                         \
    if (!(condition)) {                                                                        \
      std::fprintf(stderr, "%s:%d: SWERVE_DCHECK failed: %s\n", __FILE__, __LINE__, #condition); \
      std::abort();                                                                            \
    }                                                                                          \
  } while (false)
#else
#define SWERVE_DCHECK(condition) \
  do {                           \
  } while (false && (condition))
#endif
