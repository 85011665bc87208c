#pragma once

// glibc 2.33 and later: the table its start-up filled in.
#if __has_include(<sys/platform/x86.h>)
#include <sys/platform/x86.h>
#define RT_CPU_FEATURE(name, builtin) CPU_FEATURE_ACTIVE(name)
#else
#define RT_CPU_FEATURE(name, builtin) __builtin_cpu_supports(builtin)
#endif

namespace rt {

// Whether the CPU and the kernel let this process run AVX2 / AVX-512F code: read from the table
// the C library filled in at start-up. Asking the CPU again (cpuid, as __builtin_cpu_supports
// does at start-up) costs 12 µs per question under this project's hypervisor, 0.1 ms a process
// (bench/NOTES.md); older C libraries without the table get __builtin_cpu_supports.
inline bool cpu_runs_avx2() { return RT_CPU_FEATURE(AVX2, "avx2"); }
inline bool cpu_runs_avx512f() { return RT_CPU_FEATURE(AVX512F, "avx512f"); }

}  // namespace rt
