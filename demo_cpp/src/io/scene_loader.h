// Reads and validates an rtval-scene/1 JSON file. Every rule of docs/scene-format.md is
// enforced; nothing is rendered from an invalid file.
#pragma once

#include <stdexcept>
#include <string>

#include "core/scene.h"

namespace rt {

// The message names the file, the JSON path and what was expected, e.g.
// "scenes/x.json: spheres[3].radius: expected a finite number > 0, got -1".
class SceneError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

Scene load_scene_file(const std::string& path);
// `source_name` is used in error messages in place of a file name.
Scene parse_scene(const std::string& json_text, const std::string& source_name);

}  // namespace rt
