// Process-wide threading set-up for fem_cloth's programs.
#pragma once

namespace fem_cloth {

/// OpenMP threads that spin while they wait make fem_cloth's short parallel loops many times
/// slower as soon as another process competes for the cores (measured on 2 cores: a 65 x 65
/// projective dynamics step took 109 ms instead of 5 ms next to one busy process). libgomp reads
/// OMP_WAIT_POLICY only when it starts, so a program calls this first thing in main: when the
/// variable is unset, it sets it to "passive" and re-executes the program (same process id, same
/// arguments). A policy the user set is left alone. Does nothing without OpenMP.
void preferPassiveThreadWaiting(char** argv);

}  // namespace fem_cloth
