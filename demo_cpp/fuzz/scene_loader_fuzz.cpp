// libFuzzer target: any bytes given to the scene loader either parse or raise SceneError.
// Anything else (another exception, a crash, a sanitizer report) is a bug.
#include <cstddef>
#include <cstdint>
#include <string>

#include "io/scene_loader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        rt::parse_scene(std::string(reinterpret_cast<const char*>(data), size), "fuzz-input");
    } catch (const rt::SceneError&) {
        // the expected outcome for invalid input
    }
    return 0;
}
