#pragma once

#include <sys/platform/x86.h>

namespace rt {

// Whether the CPU and the kernel let this process run AVX2 / AVX-512F code: read from the table
// the C library filled in at start-up. Asking the CPU again (cpuid, as __builtin_cpu_supports
// does at start-up) costs 12 µs per question under this project's hypervisor, 0.1 ms a process
// (bench/NOTES.md).
inline bool cpu_runs_avx2() { return CPU_FEATURE_ACTIVE(AVX2); }
inline bool cpu_runs_avx512f() { return CPU_FEATURE_ACTIVE(AVX512F); }

}  // namespace rt
