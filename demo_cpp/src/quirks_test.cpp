#include "quirks.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace rt {
namespace {

TEST(Quirks, ModesArePresets) {
    EXPECT_EQ(quirks_for(Mode::paper).present_list(), "Q1,Q2,Q3,Q4,Q5,Q6,Q7,Q8,Q9,Q10");
    EXPECT_EQ(quirks_for(Mode::classic).present_list(), "Q1,Q3,Q5,Q6,Q7,Q8,Q10");
    EXPECT_EQ(quirks_for(Mode::physical).present_list(), "none");
}

TEST(Quirks, FixRemovesOneQuirk) {
    QuirkSet s = quirks_for(Mode::paper);
    s.fix(Quirk::Q5);
    EXPECT_FALSE(s.has(Quirk::Q5));
    EXPECT_TRUE(s.has(Quirk::Q4));
}

TEST(Quirks, ParseListAcceptsCommaSeparatedIds) {
    const auto list = parse_quirk_list("Q1,q10,Q3");
    ASSERT_EQ(list.size(), 3u);
    EXPECT_EQ(list[1], Quirk::Q10);
}

TEST(Quirks, ParseListRejectsUnknownIds) {
    EXPECT_THROW(parse_quirk_list("Q11"), std::invalid_argument);
    EXPECT_THROW(parse_quirk_list("Q1,,Q2"), std::invalid_argument);
    EXPECT_THROW(parse_quirk_list("Q1x"), std::invalid_argument);
    EXPECT_THROW(parse_quirk_list(""), std::invalid_argument);
    EXPECT_THROW(parse_mode("physics"), std::invalid_argument);
}

}  // namespace
}  // namespace rt
