#include "core/camera_rays.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rt {
namespace {

Camera looking_down_minus_z(float fov) {
    Camera c;
    c.fov_y = fov;
    return c;
}

TEST(CameraRays, CentreOfImageIsTheViewDirection) {
    const CameraRays cam(looking_down_minus_z(30), 640, 480);
    const ray r = cam.render_from_camera(320.0f, 240.0f);
    EXPECT_NEAR(r.dir.x, 0.0f, 1e-6f);
    EXPECT_NEAR(r.dir.y, 0.0f, 1e-6f);
    EXPECT_NEAR(r.dir.z, -1.0f, 1e-6f);
}

TEST(CameraRays, FovIsVerticalAndYGoesDown) {
    const CameraRays cam(looking_down_minus_z(60), 640, 480);
    const ray top = cam.render_from_camera(320.0f, 0.0f);  // top edge of the image
    EXPECT_GT(top.dir.y, 0.0f);
    EXPECT_NEAR(std::atan2(top.dir.y, -top.dir.z), 30.0f * 3.14159265f / 180.0f, 1e-5f);
    const ray right = cam.render_from_camera(640.0f, 240.0f);
    EXPECT_NEAR(right.dir.x / -right.dir.z, std::tan(30.0f * 3.14159265f / 180.0f) * 640 / 480,
                1e-5f);
}

TEST(CameraRays, PixelCentreFormulaOfPaperModel) {
    // xx = (2 (x+0.5)/W - 1) a W/H, yy = (1 - 2 (y+0.5)/H) a, dir = normalize(xx, yy, -1)
    const CameraRays cam(looking_down_minus_z(30), 7, 5);
    const float a = std::tan(15.0f * 3.14159265f / 180.0f);
    const int x = 1, y = 3;
    const float xx = (2 * (x + 0.5f) / 7 - 1) * a * 7 / 5;
    const float yy = (1 - 2 * (y + 0.5f) / 5) * a;
    const vec3 expected = normalize(vec3{xx, yy, -1});
    const ray r = cam.render_from_camera(x + 0.5f, y + 0.5f);
    EXPECT_NEAR(r.dir.x, expected.x, 1e-6f);
    EXPECT_NEAR(r.dir.y, expected.y, 1e-6f);
    EXPECT_NEAR(r.dir.z, expected.z, 1e-6f);
}

TEST(CameraRays, LookAtAndUpDefineTheFrame) {
    Camera c;
    c.position = {0, 1, 4};
    c.look_at = {0, -1.5f, -18};
    const CameraRays cam(c, 640, 480);
    const ray centre = cam.render_from_camera(320.0f, 240.0f);
    const vec3 forward = normalize(c.look_at - c.position);
    EXPECT_NEAR(dot(centre.dir, forward), 1.0f, 1e-6f);
    EXPECT_FLOAT_EQ(centre.origin.y, 1.0f);
}

}  // namespace
}  // namespace rt
