#include "core/quirks.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace rt {
namespace {

TEST(Quirks, ModesArePresets) {
    EXPECT_EQ(quirks_for(Mode::paper).present_list(), "Q1,Q2,Q3,Q4,Q5,Q6,Q7,Q8,Q9,Q10,Q11,Q12,Q13");
    EXPECT_EQ(quirks_for(Mode::classic).present_list(), "Q1,Q3,Q5,Q6,Q7,Q8,Q10");
    EXPECT_EQ(quirks_for(Mode::physical).present_list(), "none");
}

TEST(Quirks, ClassicFixesTheDirectLightQuirksToo) {
    const QuirkSet classic = quirks_for(Mode::classic);
    for (Quirk q :
         {Quirk::lit_colour_starts_at_one, Quirk::no_lambert_cosine, Quirk::no_own_emission}) {
        EXPECT_TRUE(quirks_for(Mode::paper).has(q));
        EXPECT_FALSE(classic.has(q));
    }
}

TEST(Quirks, FixRemovesOneQuirk) {
    QuirkSet s = quirks_for(Mode::paper);
    s.fix(Quirk::shadow_rays_pass_light);
    EXPECT_FALSE(s.has(Quirk::shadow_rays_pass_light));
    EXPECT_TRUE(s.has(Quirk::shared_shadow_factor));
}

TEST(Quirks, ParseListAcceptsCommaSeparatedIds) {
    const auto list = parse_quirk_list("Q1,q10,Q3,Q13");
    ASSERT_EQ(list.size(), 4u);
    EXPECT_EQ(list[1], Quirk::pixel_centre_rays);
    EXPECT_EQ(list[3], Quirk::no_own_emission);
}

TEST(Quirks, ParseListRejectsUnknownIds) {
    EXPECT_THROW(parse_quirk_list("Q14"), std::invalid_argument);
    EXPECT_THROW(parse_quirk_list("Q0"), std::invalid_argument);
    EXPECT_THROW(parse_quirk_list("Q1,,Q2"), std::invalid_argument);
    EXPECT_THROW(parse_quirk_list("Q1x"), std::invalid_argument);
    EXPECT_THROW(parse_quirk_list(""), std::invalid_argument);
    EXPECT_THROW(parse_mode("physics"), std::invalid_argument);
    try {
        parse_quirk_list("Q14");
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("Q1 ... Q13"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace rt
