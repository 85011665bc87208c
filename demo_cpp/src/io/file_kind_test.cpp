#include "io/file_kind.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace rt {
namespace {
namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
    const fs::path dir =
        fs::temp_directory_path() / ("rtdemo_file_kind_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const fs::path p = dir / name;
    std::error_code ec;
    fs::remove(p, ec);
    return p;
}

TEST(FileKind, ReadsARegularFileWithinItsBound) {
    const fs::path p = scratch("scene.json");
    std::ofstream(p) << "{}";
    EXPECT_EQ(read_regular_file(p.string(), 2), "{}");
    EXPECT_THROW(read_regular_file(p.string(), 1), FileKindError);
}

TEST(FileKind, RefusesAFifoWithoutBlocking) {
    const fs::path p = scratch("fifo.json");
    ASSERT_EQ(::mkfifo(p.c_str(), 0600), 0);
    try {
        read_regular_file(p.string(), 100);
        FAIL() << "a FIFO was read";
    } catch (const FileKindError& e) {
        EXPECT_EQ(std::string(e.what()), p.string() + ": is a FIFO, not a regular file");
    }
    EXPECT_THROW(check_replaceable(p.string()), FileKindError);
}

TEST(FileKind, RefusesASymlinkToDevZero) {
    const fs::path p = scratch("zero.json");
    fs::create_symlink("/dev/zero", p);
    EXPECT_THROW(read_regular_file(p.string(), 1 << 20), FileKindError);
    EXPECT_THROW(check_replaceable(p.string()), FileKindError);  // the link itself
    EXPECT_THROW(check_replaceable("/dev/full"), FileKindError);
}

TEST(FileKind, ReplacesOnlyRegularOrMissingFiles) {
    const fs::path p = scratch("out.exr");
    EXPECT_NO_THROW(check_replaceable(p.string()));
    std::ofstream(p) << "x";
    EXPECT_NO_THROW(check_replaceable(p.string()));
    EXPECT_THROW(check_replaceable(p.parent_path().string()), FileKindError);
}

TEST(FileKind, SameFileSeesThroughSpellings) {
    const fs::path p = scratch("a.exr");
    const std::string dotted = (p.parent_path() / "." / "a.exr").string();
    EXPECT_TRUE(same_file(p.string(), dotted));  // neither exists yet
    std::ofstream(p) << "x";
    EXPECT_TRUE(same_file(p.string(), dotted));
    EXPECT_FALSE(same_file(p.string(), scratch("b.exr").string()));
}

}  // namespace
}  // namespace rt
