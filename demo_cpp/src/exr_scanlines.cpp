#include "exr_scanlines.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "file_kind.h"

namespace rt {

namespace {

// Little-endian appends (x86 is little-endian, as the format).
void put_bytes(std::vector<char>& out, const void* p, std::size_t n) {
    const char* c = static_cast<const char*>(p);
    out.insert(out.end(), c, c + n);
}
void put_i32(std::vector<char>& out, std::int32_t v) { put_bytes(out, &v, 4); }
void put_f32(std::vector<char>& out, float v) { put_bytes(out, &v, 4); }
void put_str0(std::vector<char>& out, const std::string& s) {
    put_bytes(out, s.c_str(), s.size() + 1);
}

void put_attribute(std::vector<char>& out, const std::string& name, const char* type,
                   const std::vector<char>& value) {
    put_str0(out, name);
    put_str0(out, type);
    put_i32(out, static_cast<std::int32_t>(value.size()));
    put_bytes(out, value.data(), value.size());
}

// Only ever a regular file (as file_kind.h's outputs): opened without following a symlink and
// without blocking on a FIFO, its type checked before anything is cut or written, so a device
// or a FIFO under this name is refused untouched. (write_exr calls this on its temporary name.)
class File {
public:
    explicit File(const std::string& path) : path_(path) {
        fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0644);
        if (fd_ < 0) fail("cannot open for writing");
        struct stat st {};
        if (::fstat(fd_, &st) != 0) fail("cannot open for writing");
        if (!S_ISREG(st.st_mode))
            throw std::runtime_error(path_ + ": cannot write: it is " +
                                     describe_file_type(st.st_mode) + ", not a regular file");
        if (::ftruncate(fd_, 0) != 0) fail("cannot open for writing");
    }
    ~File() {
        if (fd_ >= 0) ::close(fd_);
    }
    File(const File&) = delete;
    File& operator=(const File&) = delete;
    void write(const char* p, std::size_t n) {
        while (n > 0) {
            const ssize_t done = ::write(fd_, p, n);
            if (done < 0 && errno == EINTR) continue;
            if (done <= 0) fail("write failed");
            p += done;
            n -= static_cast<std::size_t>(done);
        }
    }
    void close() {
        const int fd = fd_;
        fd_ = -1;
        if (::close(fd) != 0) fail("write failed");
    }

private:
    [[noreturn]] void fail(const char* what) const {
        throw std::runtime_error(path_ + ": " + what + ": " + std::strerror(errno));
    }
    std::string path_;
    int fd_ = -1;
};

}  // namespace

void write_exr_scanlines(const std::string& path, const RenderedImage& image,
                         const std::map<std::string, std::string>& attributes) {
    const int w = image.width, h = image.height;
    // Channels in name order (OpenEXR's strcmp order), each float32 with its source plane:
    // the values of pixel i are at data[stride * i + offset].
    struct Channel {
        const char* name;
        const float* data;
        int stride, offset;
    };
    const Channel channels[] = {
        {"B", image.rgb.data(), 3, 2},       {"G", image.rgb.data(), 3, 1},
        {"N.X", image.normal.data(), 3, 0},  {"N.Y", image.normal.data(), 3, 1},
        {"N.Z", image.normal.data(), 3, 2},  {"R", image.rgb.data(), 3, 0},
        {"depth", image.depth.data(), 1, 0}, {"id", image.id.data(), 1, 0},
    };
    constexpr int kChannels = 8;

    std::vector<char> head = {0x76, 0x2f, 0x31, 0x01};  // magic number
    bool long_names = false;
    for (const auto& [key, value] : attributes) long_names |= key.size() > 31;
    put_i32(head, 2 | (long_names ? 0x400 : 0));  // version 2, single-part scanline

    std::vector<char> v;
    for (const Channel& c : channels) {
        put_str0(v, c.name);
        put_i32(v, 2);                // FLOAT
        put_bytes(v, "\0\0\0\0", 4);  // pLinear, reserved
        put_i32(v, 1);                // x sampling
        put_i32(v, 1);                // y sampling
    }
    v.push_back('\0');
    std::map<std::string, std::pair<const char*, std::vector<char>>> header;  // name order
    header["channels"] = {"chlist", v};
    header["compression"] = {"compression", {0}};  // NO_COMPRESSION
    v.clear();
    for (int x : {0, 0, w - 1, h - 1}) put_i32(v, x);
    header["dataWindow"] = {"box2i", v};
    header["displayWindow"] = {"box2i", v};
    header["lineOrder"] = {"lineOrder", {0}};  // INCREASING_Y
    v.clear();
    put_f32(v, 1.0f);
    header["pixelAspectRatio"] = {"float", v};
    header["screenWindowWidth"] = {"float", v};
    v.clear();
    put_f32(v, 0.0f);
    put_f32(v, 0.0f);
    header["screenWindowCenter"] = {"v2f", v};
    for (const auto& [key, value] : attributes)
        header[key] = {"string", std::vector<char>(value.begin(), value.end())};
    for (const auto& [name, typed] : header) put_attribute(head, name, typed.first, typed.second);
    head.push_back('\0');  // end of header

    // The line offset table, then one block per line: y, byte count, each channel's row.
    const std::size_t row_bytes = static_cast<std::size_t>(w) * 4 * kChannels;
    const std::uint64_t first = head.size() + static_cast<std::size_t>(h) * 8;
    for (int y = 0; y < h; ++y) {
        const std::uint64_t offset = first + static_cast<std::uint64_t>(y) * (8 + row_bytes);
        put_bytes(head, &offset, 8);
    }
    File file(path);
    file.write(head.data(), head.size());

    // Blocks of lines through one buffer of ~256 KB: a fresh 9.8 MB buffer would cost its
    // page faults, and the kernel takes large writes as fast as small ones.
    const int lines = static_cast<int>(std::max<std::size_t>(1, (256u << 10) / (8 + row_bytes)));
    std::vector<char> buf(static_cast<std::size_t>(lines) * (8 + row_bytes));
    for (int y0 = 0; y0 < h; y0 += lines) {
        char* p = buf.data();
        const int y1 = std::min(h, y0 + lines);
        for (int y = y0; y < y1; ++y) {
            const std::int32_t header_words[2] = {y, static_cast<std::int32_t>(row_bytes)};
            std::memcpy(p, header_words, 8);
            p += 8;
            const std::size_t base = static_cast<std::size_t>(y) * w;
            for (const Channel& c : channels) {
                float* row = reinterpret_cast<float*>(p);
                if (c.stride == 1) {
                    std::memcpy(row, c.data + base, static_cast<std::size_t>(w) * 4);
                } else {
                    const float* src = c.data + 3 * base + c.offset;
                    for (int x = 0; x < w; ++x) row[x] = src[3 * x];
                }
                p += static_cast<std::size_t>(w) * 4;
            }
        }
        file.write(buf.data(), static_cast<std::size_t>(p - buf.data()));
    }
    file.close();
}

}  // namespace rt
