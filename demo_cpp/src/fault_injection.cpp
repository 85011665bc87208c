#include "fault_injection.h"

#ifdef RTDEMO_FAULT_INJECTION
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace rt {

Fault injected_fault() {
    static const Fault chosen = [] {
        const char* name = std::getenv("RTDEMO_FAULT");
        if (!name || !*name) return Fault::none;
        const struct {
            const char* name;
            Fault f;
        } table[] = {
            {"flipped_normal", Fault::flipped_normal},
            {"wrong_eta", Fault::wrong_eta},
            {"no_bias", Fault::no_bias},
            {"half_pixel_offset", Fault::half_pixel_offset},
            {"double_gamma", Fault::double_gamma},
            {"no_shadows", Fault::no_shadows},
            {"fresnel_exponent", Fault::fresnel_exponent},
            {"depth_cut", Fault::depth_cut},
        };
        for (const auto& entry : table)
            if (std::strcmp(entry.name, name) == 0) return entry.f;
        std::fprintf(stderr, "rtdemo_faulty: unknown RTDEMO_FAULT '%s'\n", name);
        std::exit(2);
    }();
    return chosen;
}

}  // namespace rt
#endif
