#include "io/streamed_outputs.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "io/exr_scanlines.h"

namespace rt {

BandFile::BandFile(const std::string& path) : file_(path) {
    check_writable(path);
    // A file without a name in the target's folder, named only by finish(): a render that is
    // interrupted or killed leaves nothing behind. Where the file system has no unnamed files,
    // the temporary name from the start (then a killed render can leave that file).
    std::string dir = std::filesystem::path(path).parent_path().string();
    if (dir.empty()) dir = ".";
    fd_ = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
    if (fd_ < 0 && (errno == EOPNOTSUPP || errno == EISDIR || errno == EINVAL)) {
        fd_ = file_.create();
        named_ = true;
    }
    if (fd_ < 0) throw OutputError(path + ": cannot open for writing: " + std::strerror(errno));
}

BandFile::~BandFile() {
    if (fd_ >= 0) ::close(fd_);
}

void BandFile::allocate(std::size_t size) {
    int r;
    while ((r = ::fallocate(fd_, 0, 0, static_cast<off_t>(size))) != 0 && errno == EINTR) {
    }
    if (r != 0 && errno != EOPNOTSUPP && errno != ENOSYS)
        throw OutputError(file_.path() + ": cannot write " + std::to_string(size) +
                          " bytes: " + std::strerror(errno));
}

void BandFile::write_at(const void* data, std::size_t n, std::size_t offset) noexcept {
    if (error_.load(std::memory_order_relaxed) != 0) return;  // the file is lost already
    if (const int error = write_fully(fd_, data, n, static_cast<off_t>(offset))) fail(error);
}

void BandFile::fail(int error) noexcept {
    int expected = 0;
    error_.compare_exchange_strong(expected, error);
}

void BandFile::finish() {
    if (error_ != 0)
        throw OutputError(file_.path() + ": write failed: " + std::strerror(error_.load()));
    if (!named_) {  // the unnamed file gets the temporary name (nothing may be there)
        const std::string self = "/proc/self/fd/" + std::to_string(fd_);
        if (::linkat(AT_FDCWD, self.c_str(), AT_FDCWD, file_.temp().c_str(), AT_SYMLINK_FOLLOW) !=
            0)
            throw OutputError(file_.path() + ": cannot name the written file " + file_.temp() +
                              ": " + std::strerror(errno));
        named_ = true;
    }
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0)
        throw OutputError(file_.path() + ": write failed: " + std::strerror(errno));
    file_.commit();
}

namespace {

// Each render thread's scratch for encoding its band, kept across bands.
std::vector<char>& thread_scratch(std::size_t n) {
    thread_local std::vector<char> scratch;
    if (scratch.size() < n) scratch.resize(n);
    return scratch;
}

}  // namespace

PpmStream::PpmStream(const std::string& path, int width, int height, PpmRounding rounding)
    : file_(path), rounding_(rounding) {
    const std::string head = ppm_header(width, height);
    header_ = head.size();
    file_.allocate(header_ +
                   3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
    file_.write_at(head.data(), header_, 0);
}

void PpmStream::band(int y0, int rows, int width, const BandPixels& pixels) noexcept {
    const BandFile::Busy busy(file_);
    const std::size_t row = 3 * static_cast<std::size_t>(width);
    const std::size_t n = row * static_cast<std::size_t>(rows);
    const std::size_t offset = header_ + row * static_cast<std::size_t>(y0);
    if (pixels.rgb8) {  // encoded by the render threads
        file_.write_at(pixels.rgb8, n, offset);
        return;
    }
    try {
        std::vector<char>& bytes = thread_scratch(n);
        unsigned char* out = reinterpret_cast<unsigned char*>(bytes.data());
        if (pixels.step == 3) {
            linear8_encode(pixels.r, n, rounding_, out);
        } else {
            for (std::size_t i = 0; i < n / 3; ++i) {
                out[3 * i + 0] = to_linear8(pixels.r[i], rounding_);
                out[3 * i + 1] = to_linear8(pixels.g[i], rounding_);
                out[3 * i + 2] = to_linear8(pixels.b[i], rounding_);
            }
        }
        file_.write_at(bytes.data(), n, offset);
    } catch (...) {  // no memory for the scratch: that band is a failed write
        file_.fail(ENOMEM);
    }
}

namespace {

std::map<std::string, std::string> padded(std::map<std::string, std::string> attributes,
                                          std::size_t spaces) {
    attributes["rtval.padding"] = std::string(spaces, ' ');
    return attributes;
}

}  // namespace

ExrStream::ExrStream(const std::string& path, int width, int height,
                     const std::map<std::string, std::string>& provisional, ExrChannels channels)
    : file_(path), width_(width), height_(height), channels_(channels) {
    header_room_ = header(provisional, 0).size() + kSlack;
    file_.allocate(header_room_ +
                   (8 + exr_line_block_bytes(width, channels)) * static_cast<std::size_t>(height));
}

std::vector<char> ExrStream::header(const std::map<std::string, std::string>& attributes,
                                    std::size_t padding) const {
    return exr_header(width_, height_, padded(attributes, padding), ExrCompression::none,
                      channels_);
}

void ExrStream::band(int y0, int rows, int width, const BandPixels& pixels) noexcept {
    const BandFile::Busy busy(file_);
    const std::size_t block = exr_line_block_bytes(width, channels_);
    const std::size_t first = header_room_ + 8 * static_cast<std::size_t>(height_);
    try {
        std::vector<char>& bytes = thread_scratch(block * static_cast<std::size_t>(rows));
        const char* end = exr_line_blocks(bytes.data(), y0, rows, width, pixels, channels_);
        file_.write_at(bytes.data(), static_cast<std::size_t>(end - bytes.data()),
                       first + block * static_cast<std::size_t>(y0));
    } catch (...) {
        file_.fail(ENOMEM);
    }
}

void ExrStream::finish(const std::map<std::string, std::string>& attributes) {
    const std::size_t bare = header(attributes, 0).size();
    if (bare > header_room_)
        throw OutputError(file_.path() + ": the EXR header's final attributes need " +
                          std::to_string(bare) + " bytes, " + std::to_string(header_room_) +
                          " were kept");
    std::vector<char> head = header(attributes, header_room_ - bare);
    const std::size_t block = exr_line_block_bytes(width_, channels_);
    const std::uint64_t first = header_room_ + 8 * static_cast<std::uint64_t>(height_);
    for (int y = 0; y < height_; ++y) {
        const std::uint64_t offset = first + static_cast<std::uint64_t>(y) * block;
        const char* b = reinterpret_cast<const char*>(&offset);
        head.insert(head.end(), b, b + 8);
    }
    file_.write_at(head.data(), head.size(), 0);
    file_.finish();
}

}  // namespace rt
