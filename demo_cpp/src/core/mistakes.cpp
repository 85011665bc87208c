#include "core/mistakes.h"

#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "embedded_mistakes.h"

namespace rt {

namespace {
#define RT_MISTAKE_NAME(name) #name,
const char* const kNames[kMistakeCount] = {RT_MISTAKE_LIST(RT_MISTAKE_NAME)};
#undef RT_MISTAKE_NAME
}  // namespace

const char* mistake_name(Mistake m) { return kNames[static_cast<int>(m)]; }

const std::vector<MistakeInfo>& mistake_catalogue() {
    static const std::vector<MistakeInfo> catalogue = [] {
        std::vector<MistakeInfo> out;
        const auto json = nlohmann::json::parse(kMistakesJson);
        for (const auto& entry : json.at("mistakes"))
            out.push_back(
                {entry.at("name").get<std::string>(), entry.at("explanation").get<std::string>()});
        return out;
    }();
    return catalogue;
}

std::string MistakeSet::list() const {
    std::string out;
    for (const MistakeInfo& info : mistake_catalogue())
        for (int i = 0; i < kMistakeCount; ++i)
            if (info.name == kNames[i] && bits_.test(i))
                out += (out.empty() ? "" : ",") + info.name;
    return out.empty() ? "none" : out;
}

MistakeSet parse_mistake_list(const std::string& text) {
    MistakeSet out;
    std::stringstream ss(text);
    std::string item;
    int count = 0;
    while (std::getline(ss, item, ',')) {
        int found = -1;
        for (int i = 0; i < kMistakeCount; ++i)
            if (item == kNames[i]) found = i;
        if (found < 0) {
            std::string known;
            for (const MistakeInfo& info : mistake_catalogue())
                known += (known.empty() ? "" : ", ") + info.name;
            throw std::invalid_argument("unknown mistake '" + item + "' (known: " + known + ")");
        }
        out.add(static_cast<Mistake>(found));
        ++count;
    }
    if (count == 0) throw std::invalid_argument("empty mistake list (expected e.g. no_offset)");
    return out;
}

}  // namespace rt
