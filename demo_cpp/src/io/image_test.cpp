// Plane: the frame's storage (image.h). Large planes are mapped on huge-page boundaries and
// zero-filled by the kernel, small ones come from the heap; both behave as a vector of floats.
#include "io/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <utility>

namespace rt {
namespace {

constexpr std::size_t kSmall = 1000;           // 4 KB: from the heap
constexpr std::size_t kLarge = 3 * 640 * 480;  // 3.7 MB: mapped

class PlaneSizes : public ::testing::TestWithParam<std::size_t> {};

TEST_P(PlaneSizes, ZeroFilledOrFilledWithTheValue) {
    const Plane zero(GetParam());
    ASSERT_EQ(zero.size(), GetParam());
    for (float v : zero) ASSERT_EQ(std::signbit(v), false) << "not +0";
    for (float v : zero) ASSERT_EQ(v, 0.0f);
    const Plane minus_one(GetParam(), -1.0f);
    for (float v : minus_one) ASSERT_EQ(v, -1.0f);
    const Plane minus_zero(GetParam(), -0.0f);
    for (float v : minus_zero) ASSERT_TRUE(v == 0.0f && std::signbit(v));
}

TEST_P(PlaneSizes, CopiesAndMovesAsAVector) {
    Plane a(GetParam());
    for (std::size_t i = 0; i < a.size(); ++i) a[i] = static_cast<float>(i % 977);
    Plane b = a;  // a copy of its own
    EXPECT_TRUE(a == b);
    b[GetParam() - 1] = -5.0f;
    EXPECT_FALSE(a == b);
    Plane c = std::move(b);
    EXPECT_TRUE(b.empty() && b.data() == nullptr);  // moved from: empty
    EXPECT_EQ(c[GetParam() - 1], -5.0f);
    c = a;
    EXPECT_TRUE(c == a);
    Plane nan(1, NAN);
    EXPECT_FALSE(nan == nan);  // element-wise ==, as std::vector<float>
}

INSTANTIATE_TEST_SUITE_P(Plane, PlaneSizes, ::testing::Values(kSmall, kLarge));

TEST(Plane, LargePlanesStartOnAHugePage) {
    const Plane p(kLarge);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p.data()) % (std::uintptr_t{2} << 20), 0u);
}

TEST(Plane, ASizeThatCannotBeMappedIsBadAlloc) {
    EXPECT_THROW(Plane(SIZE_MAX / 2), std::bad_alloc);
}

}  // namespace
}  // namespace rt
