// Named mistakes (mistakes.h) that are other settings of the same algorithm: the packet engine
// renders them as the plain scene and settings they amount to (and the other mistakes with
// switches of its own, packet_data.h Options). The scalar tracer keeps its own switch for
// each; packet_engine_test.cpp checks both give the same bits for every mistake.
#pragma once

#include "core/cpu_renderer.h"
#include "core/scene.h"

namespace rt {

struct PlainRender {
    Scene scene;
    RenderSettings settings;
};

// The scene and settings the mistakes that are settings amount to, those mistakes removed:
// no_offset is a bias of 0 (offset_at scales the bias), black_background a black background,
// depth_cut a limit one lower (-1 acts as 0: no camera ray is below it), no_shadows the
// shadows switched off, shadow_past_light quirk Q5.
PlainRender without_setting_mistakes(const Scene& scene, const RenderSettings& settings);

}  // namespace rt
