#include "core/mistakes.h"

#include <gtest/gtest.h>

#include <set>

namespace rt {
namespace {

TEST(Mistakes, CatalogueAndEnumNameTheSameMistakes) {
    std::set<std::string> in_catalogue, in_enum;
    for (const MistakeInfo& info : mistake_catalogue()) {
        in_catalogue.insert(info.name);
        EXPECT_FALSE(info.explanation.empty()) << info.name;
    }
    for (int i = 0; i < kMistakeCount; ++i) in_enum.insert(mistake_name(static_cast<Mistake>(i)));
    EXPECT_EQ(in_catalogue, in_enum);
    EXPECT_EQ(mistake_catalogue().size(), static_cast<std::size_t>(kMistakeCount));
}

TEST(Mistakes, ParsesAListAndRejectsUnknownNames) {
    const MistakeSet s = parse_mistake_list("double_gamma,no_offset");
    EXPECT_TRUE(s.has(Mistake::no_offset));
    EXPECT_TRUE(s.has(Mistake::double_gamma));
    EXPECT_FALSE(s.has(Mistake::depth_cut));
    EXPECT_EQ(s.list(), "no_offset,double_gamma");  // catalogue order
    EXPECT_EQ(MistakeSet().list(), "none");
    EXPECT_THROW(parse_mistake_list("no_ofset"), std::invalid_argument);
    EXPECT_THROW(parse_mistake_list(""), std::invalid_argument);
}

}  // namespace
}  // namespace rt
