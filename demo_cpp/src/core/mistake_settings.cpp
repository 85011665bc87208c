#include "core/mistake_settings.h"

#include <algorithm>

namespace rt {

namespace {
constexpr Mistake kSettings[] = {Mistake::no_offset, Mistake::black_background, Mistake::depth_cut,
                                 Mistake::no_shadows, Mistake::shadow_past_light};
}  // namespace

PlainRender without_setting_mistakes(const Scene& scene, const RenderSettings& settings) {
    PlainRender out{scene, settings};
    const MistakeSet& m = settings.trace.mistakes;
    TraceOptions& trace = out.settings.trace;
    if (m.has(Mistake::no_offset)) out.scene.bias = 0.0f;
    if (m.has(Mistake::black_background)) out.scene.background = color(0.0f);
    if (m.has(Mistake::depth_cut)) trace.max_depth = std::max(0, trace.max_depth - 1);
    if (m.has(Mistake::no_shadows)) trace.shadows = false;
    if (m.has(Mistake::shadow_past_light)) trace.quirks.add(Quirk::shadow_rays_pass_light);
    for (Mistake s : kSettings) trace.mistakes.remove(s);
    return out;
}

}  // namespace rt
