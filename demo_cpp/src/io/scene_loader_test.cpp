// Every rule of docs/scene-format.md, one case each: the error names the source, the JSON path
// and what was expected.
#include "io/scene_loader.h"

#include <gtest/gtest.h>

#include <cctype>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>

namespace rt {
namespace {

using json = nlohmann::json;

json valid_scene() {
    return json::parse(R"({
      "format": "rtval-scene/1", "name": "unit",
      "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 1, 0],
                 "fov_y": 30, "width": 64, "height": 48},
      "background": [2, 2, 2], "max_depth": 5, "bias": 1e-4,
      "spheres": [
        {"name": "a", "center": [0, 0, -5], "radius": 1, "color": [1, 0, 0],
         "reflection": 1, "transparency": 0.5, "ior": 1.2},
        {"name": "light", "center": [0, 5, 0], "radius": 1, "color": [0, 0, 0],
         "emission": [3, 3, 3]}
      ]})");
}

TEST(SceneLoader, ParsesEveryFieldOfAValidScene) {
    const Scene s = parse_scene(valid_scene().dump(), "unit.json");
    EXPECT_EQ(s.name, "unit");
    EXPECT_EQ(s.camera.width, 64);
    EXPECT_FLOAT_EQ(s.camera.fov_y, 30.0f);
    ASSERT_EQ(s.spheres.size(), 2u);
    EXPECT_FLOAT_EQ(s.spheres[0].ior, 1.2f);
    EXPECT_TRUE(s.spheres[0].is_glass());
    EXPECT_TRUE(s.spheres[1].is_light());
}

TEST(SceneLoader, AppliesDefaults) {
    const Scene s = parse_scene(
        R"({"format": "rtval-scene/1", "name": "d", "spheres": [
            {"name": "x", "center": [0, 0, -3], "radius": 1, "color": [1, 1, 1]}]})",
        "d.json");
    EXPECT_EQ(s.camera.width, 640);
    EXPECT_EQ(s.camera.height, 480);
    EXPECT_FLOAT_EQ(s.camera.fov_y, 30.0f);
    EXPECT_FLOAT_EQ(s.background.x, 2.0f);
    EXPECT_EQ(s.max_depth, 5);
    EXPECT_FLOAT_EQ(s.bias, 1e-4f);
    EXPECT_FLOAT_EQ(s.spheres[0].ior, 1.1f);
    EXPECT_FLOAT_EQ(s.spheres[0].reflection, 0.0f);
    EXPECT_TRUE(s.spheres[0].emission.x == 0.0f);
}

struct BadCase {
    const char* label;
    void (*mutate)(json&);
    const char* expected_path;
};

const BadCase kBadCases[] = {
    {"format missing", [](json& j) { j.erase("format"); }, "format"},
    {"format wrong", [](json& j) { j["format"] = "rtval-scene/2"; }, "format"},
    {"name missing", [](json& j) { j.erase("name"); }, "name"},
    {"name pattern", [](json& j) { j["name"] = "Bad Name"; }, "name"},
    {"unknown top key",
     [](json& j) {
         j["backgrund"] = json::array({1, 1, 1});
     },
     "backgrund"},
    {"unknown camera key", [](json& j) { j["camera"]["fov"] = 30; }, "camera.fov"},
    {"position not finite", [](json& j) { j["camera"]["position"][1] = 1e39; },
     "camera.position[1]"},
    {"position wrong length",
     [](json& j) {
         j["camera"]["position"] = json::array({0, 0});
     },
     "camera.position"},
    {"look_at equals position",
     [](json& j) {
         j["camera"]["look_at"] = json::array({0, 0, 0});
     },
     "camera.look_at"},
    {"up parallel",
     [](json& j) {
         j["camera"]["up"] = json::array({0, 0, -2});
     },
     "camera.up"},
    {"fov zero", [](json& j) { j["camera"]["fov_y"] = 0; }, "camera.fov_y"},
    {"fov 180", [](json& j) { j["camera"]["fov_y"] = 180; }, "camera.fov_y"},
    {"width zero", [](json& j) { j["camera"]["width"] = 0; }, "camera.width"},
    {"width too big", [](json& j) { j["camera"]["width"] = 16385; }, "camera.width"},
    {"height not integer", [](json& j) { j["camera"]["height"] = 48.5; }, "camera.height"},
    {"background negative", [](json& j) { j["background"][2] = -0.1; }, "background[2]"},
    {"background string", [](json& j) { j["background"] = "white"; }, "background"},
    {"max_depth too deep", [](json& j) { j["max_depth"] = 65; }, "max_depth"},
    {"max_depth negative", [](json& j) { j["max_depth"] = -1; }, "max_depth"},
    {"bias zero", [](json& j) { j["bias"] = 0; }, "bias"},
    {"spheres missing", [](json& j) { j.erase("spheres"); }, "spheres"},
    {"spheres not array", [](json& j) { j["spheres"] = json::object(); }, "spheres"},
    {"sphere name missing", [](json& j) { j["spheres"][0].erase("name"); }, "spheres[0].name"},
    {"sphere name duplicate", [](json& j) { j["spheres"][1]["name"] = "a"; }, "spheres[1].name"},
    {"sphere center missing", [](json& j) { j["spheres"][0].erase("center"); },
     "spheres[0].center"},
    {"sphere center NaN-like", [](json& j) { j["spheres"][0]["center"][0] = "nan"; },
     "spheres[0].center[0]"},
    {"radius missing", [](json& j) { j["spheres"][1].erase("radius"); }, "spheres[1].radius"},
    {"radius zero", [](json& j) { j["spheres"][0]["radius"] = 0; }, "spheres[0].radius"},
    {"radius negative", [](json& j) { j["spheres"][0]["radius"] = -1; }, "spheres[0].radius"},
    {"color missing", [](json& j) { j["spheres"][0].erase("color"); }, "spheres[0].color"},
    {"color negative", [](json& j) { j["spheres"][0]["color"][1] = -1; }, "spheres[0].color[1]"},
    {"reflection negative", [](json& j) { j["spheres"][0]["reflection"] = -0.5; },
     "spheres[0].reflection"},
    {"transparency above 1", [](json& j) { j["spheres"][0]["transparency"] = 1.5; },
     "spheres[0].transparency"},
    {"ior below 1", [](json& j) { j["spheres"][0]["ior"] = 0.9; }, "spheres[0].ior"},
    {"emission negative", [](json& j) { j["spheres"][1]["emission"][0] = -3; },
     "spheres[1].emission[0]"},
    {"unknown sphere key",
     [](json& j) {
         j["spheres"][0]["colour"] = json::array({1, 1, 1});
     },
     "spheres[0].colour"},
    {"sphere not object", [](json& j) { j["spheres"][0] = 3; }, "spheres[0]"},
    {"boolean as number", [](json& j) { j["bias"] = true; }, "bias"},
};

// GoogleTest prints a parameter in failure messages; by default as its raw bytes.
void PrintTo(const BadCase& c, std::ostream* os) { *os << '"' << c.label << '"'; }

class SceneLoaderRejects : public testing::TestWithParam<BadCase> {};

TEST_P(SceneLoaderRejects, NamingFileAndPath) {
    json j = valid_scene();
    GetParam().mutate(j);
    try {
        parse_scene(j.dump(), "bad.json");
        FAIL() << GetParam().label << ": accepted";
    } catch (const SceneError& e) {
        const std::string msg = e.what();
        EXPECT_EQ(msg.rfind("bad.json: ", 0), 0u) << msg;
        EXPECT_NE(msg.find(std::string(": ") + GetParam().expected_path + ": "), std::string::npos)
            << GetParam().label << ": " << msg;
        EXPECT_NE(msg.find("expected"), std::string::npos) << msg;
    }
}

// Test names from each case's label ("fov zero" -> .../NamingFileAndPath/fov_zero): readable
// and stable from build to build, where the default printed the case's bytes. GoogleTest allows
// letters, digits and underscores only, and stops at start-up on a duplicate name.
std::string case_name(const testing::TestParamInfo<BadCase>& info) {
    std::string name = info.param.label;
    for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return name;
}

INSTANTIATE_TEST_SUITE_P(EveryRule, SceneLoaderRejects, testing::ValuesIn(kBadCases), case_name);

TEST(SceneLoader, InvalidJsonNamesLineAndColumn) {
    try {
        parse_scene("{\n  \"format\": \"rtval-scene/1\",\n  \"name\": oops\n}", "broken.json");
        FAIL() << "accepted";
    } catch (const SceneError& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("broken.json: invalid JSON at line 3, column"), std::string::npos)
            << msg;
    }
}

// Found by scene_loader_fuzz: nlohmann reports an overflowing literal as out_of_range,
// not as a parse error; it must still be a SceneError.
TEST(SceneLoader, OverflowingNumberLiteralIsASceneError) {
    EXPECT_THROW(parse_scene("9e6666 of669e", "fuzz.json"), SceneError);
    EXPECT_THROW(
        parse_scene(R"({"format": "rtval-scene/1", "name": "x", "bias": 1e99999, "spheres": []})",
                    "big.json"),
        SceneError);
}

TEST(SceneLoader, MissingFileIsASceneError) {
    EXPECT_THROW(load_scene_file("/nonexistent/scene.json"), SceneError);
}

// The hostile-input pass: each of these crashed rtdemo (stack overflow) or was accepted where
// the Python loader refuses it.
TEST(SceneLoader, HostileDocumentsAreSceneErrorsNotCrashes) {
    const std::string head = R"({"format": "rtval-scene/1", "name": ")";
    EXPECT_THROW(parse_scene(head + std::string(1000000, 'a') + "x!\", \"spheres\": []}", "n"),
                 SceneError);  // std::regex recursed once per character
    EXPECT_THROW(parse_scene(std::string(1000000, '['), "a.json"), SceneError);
    std::string braces;
    for (int i = 0; i < 100000; ++i) braces += "{\"a\":";
    EXPECT_THROW(parse_scene(braces, "o.json"), SceneError);
    const std::string ok = R"({"format": "rtval-scene/1", "name": "e", "spheres": []})";
    EXPECT_NO_THROW(parse_scene(ok, "e.json"));
    EXPECT_THROW(parse_scene(ok + std::string(1, '\0'), "nul.json"), SceneError);
    const std::string nul_name = R"({"format": "rtval-scene/1", "name": "e", "spheres": [
        {"name": "a\u0000b", "center": [0, 0, -5], "radius": 1, "color": [1, 1, 1]}]})";
    EXPECT_THROW(parse_scene(nul_name, "nul_name.json"), SceneError);
}

TEST(SceneLoader, NestingUpToTheLimitStillParses) {
    // 64 levels inside a string do not count; 64 real levels are allowed (then a field error).
    const std::string deep = std::string(64, '[') + std::string(64, ']');
    try {
        parse_scene(deep, "deep.json");
        FAIL() << "accepted";
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("expected a JSON object"), std::string::npos)
            << e.what();
    }
}

TEST(SceneLoader, EmptySphereListIsAllowed) {
    const Scene s =
        parse_scene(R"({"format": "rtval-scene/1", "name": "e", "spheres": []})", "e.json");
    EXPECT_TRUE(s.spheres.empty());
}

}  // namespace
}  // namespace rt
