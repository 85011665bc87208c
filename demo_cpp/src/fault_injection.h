// Deliberate bugs for testing `rtval check` (issue 5). Only the test-only binary
// rtdemo_faulty is compiled with RTDEMO_FAULT_INJECTION; in rtdemo every fault() is a
// constant false that the compiler removes, so users cannot reach them.
#pragma once

namespace rt {

enum class Fault {
    none,
    flipped_normal,     // shading normal points into the surface
    wrong_eta,          // eta = ior when entering glass instead of 1/ior
    no_bias,            // secondary rays start exactly on the surface
    half_pixel_offset,  // camera rays through pixel corners instead of centres
    double_gamma,       // output encoded with gamma 1/2.2 on top of linear
    no_shadows,         // shadow rays never blocked
    fresnel_exponent,   // (1 - cos)^2 instead of ^3 in the paper's Fresnel mix
    depth_cut,          // recursion one level shallower than asked
};

#ifdef RTDEMO_FAULT_INJECTION
// The fault named by the environment variable RTDEMO_FAULT (read once), or none.
Fault injected_fault();
inline bool fault(Fault f) { return injected_fault() == f; }
#else
constexpr bool fault(Fault) { return false; }
#endif

}  // namespace rt
