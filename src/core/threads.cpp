#include "fem_cloth/core/threads.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>

namespace fem_cloth {

void preferPassiveThreadWaiting(char** argv) {
#ifdef _OPENMP
  if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  setenv("OMP_WAIT_POLICY", "passive", 0);
  execv("/proc/self/exe", argv);
  // Only reached if the re-execution failed: go on with the default (spinning) policy.
  std::perror("fem_cloth: cannot re-execute with OMP_WAIT_POLICY=passive");
#else
  (void)argv;
#endif
}

}  // namespace fem_cloth
