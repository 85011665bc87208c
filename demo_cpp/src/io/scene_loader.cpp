#include "io/scene_loader.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "io/file_kind.h"

namespace rt {
namespace {

using json = nlohmann::json;

// Validation context: where we are in the document, for error messages.
class Validator {
public:
    explicit Validator(std::string source) : source_(std::move(source)) {}

    [[noreturn]] void fail(const std::string& path, const std::string& expected,
                           const json* got = nullptr) const {
        std::string msg = source_ + ": " + (path.empty() ? "(top level)" : path) + ": " + expected;
        if (got) msg += ", got " + got->dump();
        throw SceneError(msg);
    }

    void only_keys(const json& obj, const std::string& path,
                   std::initializer_list<const char*> allowed) const {
        for (auto it = obj.begin(); it != obj.end(); ++it) {
            bool known = false;
            for (const char* k : allowed) known = known || it.key() == k;
            if (!known) {
                std::string list;
                for (const char* k : allowed) list += std::string(list.empty() ? "" : ", ") + k;
                fail(join(path, it.key()), "unknown key; expected one of: " + list);
            }
        }
    }

    static std::string join(const std::string& path, const std::string& key) {
        return path.empty() ? key : path + "." + key;
    }

    // A float32-finite number satisfying `ok`; `rule` describes it.
    template <class Pred>
    float number(const json& v, const std::string& path, const std::string& rule, Pred ok) const {
        if (!v.is_number()) fail(path, "expected a number " + rule, &v);
        const double d = v.get<double>();
        const float f = static_cast<float>(d);
        if (!std::isfinite(d) || !std::isfinite(f) || !ok(f))
            fail(path, "expected a finite number " + rule, &v);
        return f;
    }

    template <class Pred>
    vec3 triple(const json& v, const std::string& path, const std::string& rule, Pred ok) const {
        if (!v.is_array() || v.size() != 3)
            fail(path, "expected an array of 3 numbers " + rule, &v);
        vec3 out;
        float* comps[3] = {&out.x, &out.y, &out.z};
        for (int i = 0; i < 3; ++i)
            *comps[i] = number(v[i], path + "[" + std::to_string(i) + "]", rule, ok);
        return out;
    }

    int integer(const json& v, const std::string& path, int lo, int hi) const {
        const std::string rule = "from " + std::to_string(lo) + " to " + std::to_string(hi);
        if (!v.is_number_integer()) fail(path, "expected an integer " + rule, &v);
        const long long i = v.get<long long>();
        if (i < lo || i > hi) fail(path, "expected an integer " + rule, &v);
        return static_cast<int>(i);
    }

    std::string string(const json& v, const std::string& path) const {
        if (!v.is_string()) fail(path, "expected a string", &v);
        return v.get<std::string>();
    }

private:
    std::string source_;
};

// The scene's name becomes part of file names: 1-64 of [a-z0-9_-] (a loop: std::regex recurses per
// character and overflows the stack on a long name).
bool is_file_name_word(const std::string& name) {
    if (name.empty() || name.size() > 64) return false;  // file names stay short
    for (const char c : name)
        if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-'))
            return false;
    return true;
}

// A sphere name lands in XML, HTML and file names: no control characters (NUL among them).
bool has_control_character(const std::string& text) {
    for (const char c : text)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return true;
    return false;
}

// The deepest nesting of [ and { outside strings: nlohmann json recurses once per level and a
// deep document would overflow the stack (the same scan and limit as scene_model/scene.py).
int nesting_depth(const std::string& text) {
    int depth = 0, deepest = 0;
    bool in_string = false;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (in_string) {
            if (c == '\\')
                ++i;
            else if (c == '"')
                in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            deepest = std::max(deepest, ++depth);
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
    return deepest;
}

constexpr int kMaxNesting = 64;
constexpr float kInfinity = std::numeric_limits<float>::infinity();

const auto any = [](float) { return true; };
const auto non_negative = [](float f) { return f >= 0; };
const auto positive = [](float f) { return f > 0; };

// Line and column (1-based) of a byte offset, for JSON syntax errors.
std::pair<int, int> line_column(const std::string& text, std::size_t byte) {
    int line = 1, col = 1;
    for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
        if (text[i] == '\n') {
            ++line;
            col = 1;
        } else {
            ++col;
        }
    }
    return {line, col};
}

Camera parse_camera(const json& j, const Validator& v) {
    Camera cam;
    if (!j.is_object()) v.fail("camera", "expected an object", &j);
    v.only_keys(j, "camera", {"position", "look_at", "up", "fov_y", "width", "height"});
    if (j.contains("position")) cam.position = v.triple(j["position"], "camera.position", "", any);
    if (j.contains("look_at")) cam.look_at = v.triple(j["look_at"], "camera.look_at", "", any);
    if (j.contains("up")) cam.up = v.triple(j["up"], "camera.up", "", any);
    if (j.contains("fov_y"))
        cam.fov_y = v.number(j["fov_y"], "camera.fov_y", "in (0, 180) degrees",
                             [](float f) { return f > 0 && f < 180; });
    if (j.contains("width")) cam.width = v.integer(j["width"], "camera.width", 1, 16384);
    if (j.contains("height")) cam.height = v.integer(j["height"], "camera.height", 1, 16384);

    // Lengths that are neither zero (nor underflow to it) nor overflow; NaN fails every test.
    const vec3 view = cam.look_at - cam.position;
    const float vv = dot(view, view), uu = dot(cam.up, cam.up);
    if (!(vv > 0.0f && vv < kInfinity))
        v.fail("camera.look_at", "expected a point different from camera.position");
    const vec3 side = cross(view / std::sqrt(vv), cam.up);
    if (!(uu > 0.0f && uu < kInfinity && std::sqrt(dot(side, side)) >= 1e-6f * std::sqrt(uu)))
        v.fail("camera.up", "expected a direction not parallel to the view direction");
    return cam;
}

Sphere parse_sphere(const json& j, const std::string& path, const Validator& v) {
    if (!j.is_object()) v.fail(path, "expected an object", &j);
    v.only_keys(
        j, path,
        {"name", "center", "radius", "color", "reflection", "transparency", "ior", "emission"});
    for (const char* req : {"name", "center", "radius", "color"})
        if (!j.contains(req)) v.fail(path + "." + req, "missing; expected this required key");
    Sphere s;
    s.name = v.string(j["name"], path + ".name");
    if (s.name.empty()) v.fail(path + ".name", "expected a non-empty string", &j["name"]);
    if (has_control_character(s.name))
        v.fail(path + ".name", "expected a name without control characters", &j["name"]);
    s.center = v.triple(j["center"], path + ".center", "", any);
    s.radius = v.number(j["radius"], path + ".radius", "> 0", positive);
    s.surface_color = v.triple(j["color"], path + ".color", ">= 0", non_negative);
    if (j.contains("reflection"))
        s.reflection = v.number(j["reflection"], path + ".reflection", ">= 0", non_negative);
    if (j.contains("transparency"))
        s.transparency = v.number(j["transparency"], path + ".transparency", "from 0 to 1",
                                  [](float f) { return f >= 0 && f <= 1; });
    if (j.contains("ior"))
        s.ior = v.number(j["ior"], path + ".ior", ">= 1", [](float f) { return f >= 1; });
    if (j.contains("emission"))
        s.emission = v.triple(j["emission"], path + ".emission", ">= 0", non_negative);
    return s;
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& source) {
    if (text.find('\0') != std::string::npos)
        throw SceneError(source + ": invalid JSON: contains a NUL byte");
    const int depth = nesting_depth(text);
    if (depth > kMaxNesting)
        throw SceneError(source + ": invalid JSON: nested " + std::to_string(depth) +
                         " levels deep, at most " + std::to_string(kMaxNesting) + " allowed");
    json root;
    try {
        root = json::parse(text);
    } catch (const json::parse_error& e) {
        const auto [line, col] = line_column(text, e.byte == 0 ? 0 : e.byte - 1);
        throw SceneError(source + ": invalid JSON at line " + std::to_string(line) + ", column " +
                         std::to_string(col) + ": " + e.what());
    } catch (const json::exception& e) {
        // e.g. out_of_range for a literal like 9e6666 (found by the fuzzer)
        throw SceneError(source + ": invalid JSON: " + e.what());
    }
    const Validator v(source);
    if (!root.is_object()) v.fail("", "expected a JSON object");
    v.only_keys(
        root, "",
        {"format", "name", "description", "camera", "background", "max_depth", "bias", "spheres"});

    Scene scene;
    if (!root.contains("format")) v.fail("format", "missing; expected \"rtval-scene/1\"");
    if (!root["format"].is_string() || root["format"] != "rtval-scene/1")
        v.fail("format", "expected exactly \"rtval-scene/1\"", &root["format"]);
    if (!root.contains("name"))
        v.fail("name", "missing; expected a name of 1-64 characters [a-z0-9_-]");
    scene.name = v.string(root["name"], "name");
    if (!is_file_name_word(scene.name))
        v.fail("name", "expected a name of 1-64 characters [a-z0-9_-]", &root["name"]);
    if (root.contains("description"))
        scene.description = v.string(root["description"], "description");
    if (root.contains("camera")) scene.camera = parse_camera(root["camera"], v);
    if (root.contains("background"))
        scene.background = v.triple(root["background"], "background", ">= 0", non_negative);
    if (root.contains("max_depth"))
        scene.max_depth = v.integer(root["max_depth"], "max_depth", 0, 64);
    if (root.contains("bias")) scene.bias = v.number(root["bias"], "bias", "> 0", positive);

    if (!root.contains("spheres")) v.fail("spheres", "missing; expected an array of spheres");
    const json& spheres = root["spheres"];
    if (!spheres.is_array()) v.fail("spheres", "expected an array", &spheres);
    std::set<std::string> names;
    for (std::size_t i = 0; i < spheres.size(); ++i) {
        const std::string path = "spheres[" + std::to_string(i) + "]";
        Sphere s = parse_sphere(spheres[i], path, v);
        if (!names.insert(s.name).second)
            v.fail(path + ".name", "expected a unique name; \"" + s.name + "\" is used twice");
        scene.spheres.push_back(std::move(s));
    }
    return scene;
}

Scene load_scene_file(const std::string& path) {
    // A regular file only, read with a bound: a FIFO would block, /dev/zero never ends
    // (the same rule and bound as scene_model/scene.py).
    constexpr std::size_t kMaxSceneBytes = 16u << 20;
    std::string text;
    try {
        text = read_regular_file(path, kMaxSceneBytes);
    } catch (const FileKindError& e) {
        throw SceneError(std::string("cannot read the scene file: ") + e.what());
    }
    return parse_scene(text, path);
}

}  // namespace rt
