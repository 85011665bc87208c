#include "core/fresnel.h"

#include <gtest/gtest.h>

#include "core/optics.h"

namespace rt {
namespace {

TEST(PaperFresnel, MixOfCubeWithTenPercentFloor) {
    EXPECT_FLOAT_EQ(paper_fresnel(1.0f), 0.1f);  // facing the viewer
    EXPECT_FLOAT_EQ(paper_fresnel(0.0f), 1.0f);  // grazing
    EXPECT_FLOAT_EQ(paper_fresnel(0.5f), 0.1f + 0.9f * 0.125f);
}

// The default curve is the paper's expression to the bit (renders made before the curve had
// parameters stay valid); other constants follow mix + (1 - mix) (1 - facing)^power.
TEST(PaperFresnel, DefaultCurveIsThePapersExpressionBitForBit) {
    for (float facing = 0.0f; facing <= 1.0f; facing += 1.0f / 64) {
        const float f = 1.0f - facing;
        EXPECT_EQ(paper_fresnel(facing), 0.1f + 0.9f * f * f * f);
        EXPECT_EQ(paper_fresnel(facing, {0.1f, 2}), 0.1f + 0.9f * f * f);
    }
    EXPECT_FLOAT_EQ(paper_fresnel(0.25f, {1.0f, 3}), 1.0f);  // a mirror at every angle
    EXPECT_FLOAT_EQ(paper_fresnel(0.5f, {0.9f, 3}), 0.9f + 0.1f * 0.125f);
    EXPECT_FLOAT_EQ(paper_fresnel(0.5f, {0.04f, 5}), 0.04f + 0.96f / 32);  // Schlick's form
    EXPECT_FLOAT_EQ(paper_fresnel(0.5f, {0.3f, 0}), 1.0f);
}

TEST(DielectricFresnel, NormalIncidenceIsSquaredIndexRatio) {
    EXPECT_NEAR(dielectric_fresnel(1.0f, 1.5f), 0.04f, 1e-6f);
    EXPECT_NEAR(dielectric_fresnel(-1.0f, 1.5f), 0.04f, 1e-6f);  // from inside
    EXPECT_NEAR(dielectric_fresnel(1.0f, 1.2f), (0.2f / 2.2f) * (0.2f / 2.2f), 1e-6f);
}

TEST(DielectricFresnel, TotalInternalReflectionBeyondCriticalAngle) {
    // From inside glass of index 1.5 the critical cosine is sqrt(1 - 1/2.25) = 0.745.
    EXPECT_FLOAT_EQ(dielectric_fresnel(-0.5f, 1.5f), 1.0f);
    EXPECT_LT(dielectric_fresnel(-0.9f, 1.5f), 1.0f);
}

TEST(DielectricFresnel, ReciprocalAcrossTheInterface) {
    // Reflectance seen from outside at cos_i equals that seen from inside at cos_t.
    const float cos_i = 0.6f, eta = 1.33f;
    const float sin_t = std::sqrt(1 - cos_i * cos_i) / eta;
    const float cos_t = std::sqrt(1 - sin_t * sin_t);
    EXPECT_NEAR(dielectric_fresnel(cos_i, eta), dielectric_fresnel(-cos_t, eta), 1e-6f);
    EXPECT_FLOAT_EQ(dielectric_fresnel(0.3f, 1.0f), 0.0f);
}

TEST(Optics, ReflectionKeepsTheAngle) {
    const vec3 d = normalize(vec3{1, -1, 0});
    const vec3 r = reflect(d, {0, 1, 0});
    EXPECT_NEAR(r.x, d.x, 1e-6f);
    EXPECT_NEAR(r.y, -d.y, 1e-6f);
}

TEST(Optics, RefractionObeysSnell) {
    const vec3 d = normalize(vec3{0.5f, -1, 0});
    const vec3 n{0, 1, 0};
    const float eta = 1.0f / 1.2f;
    const vec3 t = refract(d, n, eta);
    EXPECT_NEAR(t.x, eta * d.x, 1e-6f);  // sin_t = eta sin_i, tangential component scales
    EXPECT_LT(t.y, 0.0f);
    EXPECT_NEAR(length(t), 1.0f, 1e-6f);
}

TEST(Optics, TotalInternalReflectionGivesNegativeKAndNaNDirection) {
    const vec3 d = normalize(vec3{1, -0.3f, 0});  // grazing, leaving glass of index 1.5
    const vec3 n{0, 1, 0};
    EXPECT_LT(refraction_k(d, n, 1.5f), 0.0f);
    EXPECT_TRUE(std::isnan(refract(d, n, 1.5f).x));
}

}  // namespace
}  // namespace rt
