#include "io/exr_scanlines.h"

// The compressed blocks follow the file format's description (not OpenEXR's code): the block's
// bytes split into even and odd positions, each byte replaced by its difference to the one
// before (+128), then zlib (ZIP) or signed-count run-length coding (RLE).
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <vector>

#include "core/worker_threads.h"
#include "io/file_kind.h"
#include "io/output_file.h"

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
        if (const int error = write_fully(fd_, p, n)) {
            errno = error;
            fail("write failed");
        }
    }
    // Gathers the pieces in one call per IOV_MAX of them, resuming after a short write.
    void writev(std::vector<iovec>& pieces) {
        std::size_t i = 0;
        while (i < pieces.size()) {
            const int count = static_cast<int>(std::min<std::size_t>(pieces.size() - i, IOV_MAX));
            ssize_t done = ::writev(fd_, &pieces[i], count);
            if (done < 0 && errno == EINTR) continue;
            if (done <= 0) fail("write failed");
            while (i < pieces.size() && static_cast<std::size_t>(done) >= pieces[i].iov_len)
                done -= static_cast<ssize_t>(pieces[i++].iov_len);
            if (done > 0) {
                pieces[i].iov_base = static_cast<char*>(pieces[i].iov_base) + done;
                pieces[i].iov_len -= static_cast<std::size_t>(done);
            }
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

// The channels in name order (OpenEXR's strcmp order), each float32 with its source: the
// value of pixel i is data[stride * i].
struct Channel {
    const char* name;
    const float* data;
    int stride;
};
constexpr int kMaxChannels = 9;
struct Channels {
    std::array<Channel, kMaxChannels> list;
    int count;
    const Channel* begin() const { return list.data(); }
    const Channel* end() const { return list.data() + count; }
};

int channel_count(ExrChannels set) {
    return (exr_has_aovs(set) ? 8 : 3) + (exr_has_path(set) ? 1 : 0);
}

Channels channels_of(const BandPixels& p, ExrChannels set) {
    Channels out{{}, 0};
    auto add = [&out](const char* name, const float* data, int stride) {
        out.list[static_cast<std::size_t>(out.count++)] = {name, data, stride};
    };
    add("B", p.b, p.step);
    add("G", p.g, p.step);
    if (exr_has_aovs(set)) {
        add("N.X", p.nx, p.step);
        add("N.Y", p.ny, p.step);
        add("N.Z", p.nz, p.step);
    }
    add("R", p.r, p.step);
    if (exr_has_aovs(set)) {
        add("depth", p.depth, 1);
        add("id", p.id, 1);
    }
    if (exr_has_path(set)) add("path", p.path, 1);
    return out;
}

// The uncompressed bytes of lines [y0, y1): for each line, each channel's row of floats.
// Returns the end of what was written.
char* put_lines(char* p, const Channels& channels, int w, int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
        const std::size_t base = static_cast<std::size_t>(y) * w;
        for (const Channel& c : channels) {
            float* row = reinterpret_cast<float*>(p);
            if (c.stride == 1) {
                std::memcpy(row, c.data + base, static_cast<std::size_t>(w) * 4);
            } else {
                const float* src = c.data + 3 * base;
                for (int x = 0; x < w; ++x) row[x] = src[3 * x];
            }
            p += static_cast<std::size_t>(w) * 4;
        }
    }
    return p;
}

// The filter both ZIP and RLE apply first: the bytes at even positions, then those at odd
// positions (the first half gets (n + 1) / 2), each byte after the first then replaced by its
// difference to the byte before it in that order, + 128 (mod 256).
void reorder_and_predict(const unsigned char* in, std::size_t n, unsigned char* out) {
    unsigned char* even = out;
    unsigned char* odd = out + (n + 1) / 2;
    std::size_t i = 0;
    for (; i + 1 < n; i += 2) {
        *even++ = in[i];
        *odd++ = in[i + 1];
    }
    if (i < n) *even = in[i];
    unsigned char prev = out[0];
    for (std::size_t k = 1; k < n; ++k) {
        const unsigned char t = out[k];
        out[k] = static_cast<unsigned char>(t - prev + 128);
        prev = t;
    }
}

// Run-length codes in[0, n) into out: a count byte c >= 0 repeats the next byte c + 1 times
// (runs of 3 to 128), c < 0 is followed by -c literal bytes (1 to 127). Returns the coded
// size, or 0 when it would not be smaller than n (out holds n - 1 bytes).
std::size_t rle_encode(const unsigned char* in, std::size_t n, unsigned char* out) {
    const std::size_t cap = n - 1;
    std::size_t o = 0, i = 0;
    // The length of the run of equal bytes starting at j, at most 128.
    auto run_at = [&](std::size_t j) {
        std::size_t r = 1;
        while (j + r < n && r < 128 && in[j + r] == in[j]) ++r;
        return r;
    };
    while (i < n) {
        const std::size_t run = run_at(i);
        if (run >= 3) {
            if (o + 2 > cap) return 0;
            out[o++] = static_cast<unsigned char>(run - 1);
            out[o++] = in[i];
            i += run;
            continue;
        }
        std::size_t j = i + run;  // literals up to the next run of 3, at most 127 of them
        while (j < n && j - i < 127) {
            if (j + 2 < n && in[j] == in[j + 1] && in[j] == in[j + 2]) break;
            ++j;
        }
        const std::size_t count = j - i;
        if (o + 1 + count > cap) return 0;
        out[o++] = static_cast<unsigned char>(-static_cast<int>(count));
        std::memcpy(out + o, in + i, count);
        o += count;
        i = j;
    }
    return o;
}

}  // namespace

std::vector<char> exr_header(int w, int h, const std::map<std::string, std::string>& attributes,
                             ExrCompression compression, ExrChannels channels) {
    std::vector<char> head = {0x76, 0x2f, 0x31, 0x01};  // magic number
    bool long_names = false;
    for (const auto& [key, value] : attributes) long_names |= key.size() > 31;
    put_i32(head, 2 | (long_names ? 0x400 : 0));  // version 2, single-part scanline

    std::vector<char> v;
    for (const Channel& c : channels_of(BandPixels{}, channels)) {
        put_str0(v, c.name);
        put_i32(v, 2);                // FLOAT
        put_bytes(v, "\0\0\0\0", 4);  // pLinear, reserved
        put_i32(v, 1);                // x sampling
        put_i32(v, 1);                // y sampling
    }
    v.push_back('\0');
    std::map<std::string, std::pair<const char*, std::vector<char>>> header;  // name order
    header["channels"] = {"chlist", v};
    // NO_COMPRESSION, RLE_COMPRESSION, ZIP_COMPRESSION (16 lines per block)
    const char code = compression == ExrCompression::zip   ? 3
                      : compression == ExrCompression::rle ? 1
                                                           : 0;
    header["compression"] = {"compression", {code}};
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

    return head;
}

std::size_t exr_line_block_bytes(int w, ExrChannels channels) {
    return 8 + static_cast<std::size_t>(w) * 4 * channel_count(channels);
}

char* exr_line_blocks(char* out, int y0, int rows, int w, const BandPixels& pixels,
                      ExrChannels set) {
    const Channels channels = channels_of(pixels, set);
    const std::int32_t row_bytes = static_cast<std::int32_t>(exr_line_block_bytes(w, set) - 8);
    for (int r = 0; r < rows; ++r) {
        const std::int32_t header_words[2] = {y0 + r, row_bytes};
        std::memcpy(out, header_words, 8);
        out = put_lines(out + 8, channels, w, r, r + 1);
    }
    return out;
}

namespace {

// The frame's planes from pixel `first` on; an AOV the frame has not is null.
BandPixels frame_pixels(const RenderedImage& image, std::size_t first) {
    auto at = [first](const auto& plane, std::size_t per_pixel) {
        return plane.empty() ? nullptr : plane.data() + per_pixel * first;
    };
    BandPixels p = interleaved_pixels(at(image.rgb, 3), at(image.id, 1), at(image.depth, 1),
                                      at(image.normal, 3));
    p.path = at(image.path, 1);
    return p;
}

void check_has_planes(const std::string& path, const RenderedImage& image, ExrChannels set) {
    const std::size_t pixels =
        static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
    if (image.rgb.size() != 3 * pixels) throw std::runtime_error(path + ": the frame has no RGB");
    if (exr_has_path(set) && image.path.size() != pixels)
        throw std::runtime_error(path + ": the frame has no path plane to write");
    if (exr_has_aovs(set) && (image.normal.size() != 3 * pixels || image.id.size() != pixels ||
                              image.depth.size() != pixels))
        throw std::runtime_error(path +
                                 ": the frame has no AOV planes to write (rendered "
                                 "with RenderSettings::aovs off)");
}

// The line offset table, then one block per line: y, byte count, each channel's row.
void write_uncompressed(File& file, std::vector<char>& head, const RenderedImage& image,
                        ExrChannels set) {
    const int w = image.width, h = image.height;
    const std::size_t row_bytes = exr_line_block_bytes(w, set) - 8;
    const std::uint64_t first = head.size() + static_cast<std::size_t>(h) * 8;
    for (int y = 0; y < h; ++y) {
        const std::uint64_t offset = first + static_cast<std::uint64_t>(y) * (8 + row_bytes);
        put_bytes(head, &offset, 8);
    }
    file.write(head.data(), head.size());

    // Blocks of lines through one buffer of ~256 KB: a fresh 9.8 MB buffer would cost its
    // page faults, and the kernel takes large writes as fast as small ones.
    const int lines = static_cast<int>(std::max<std::size_t>(1, (256u << 10) / (8 + row_bytes)));
    std::vector<char> buf(static_cast<std::size_t>(lines) * (8 + row_bytes));
    for (int y0 = 0; y0 < h; y0 += lines) {
        const std::size_t first = static_cast<std::size_t>(y0) * w;
        const char* end = exr_line_blocks(buf.data(), y0, std::min(h, y0 + lines) - y0, w,
                                          frame_pixels(image, first), set);
        file.write(buf.data(), static_cast<std::size_t>(end - buf.data()));
    }
}

// Every block compressed into its own slot of one buffer (y, byte count, data; a slot holds
// the raw block, so a block that does not shrink is copied in raw). The buffer is not zeroed:
// only the pages the compressed blocks use are touched.
class CompressedBlocks {
public:
    CompressedBlocks(const Channels& channels, int w, int h, ExrCompression compression)
        : channels_(channels),
          w_(w),
          h_(h),
          compression_(compression),
          row_bytes_(static_cast<std::size_t>(w) * 4 * channels.count),
          block_lines_(compression == ExrCompression::zip ? 16 : 1),
          blocks_((h + block_lines_ - 1) / block_lines_),
          slot_(8 + row_bytes_ * block_lines_),
          out_(new char[slot_ * static_cast<std::size_t>(blocks_)]),
          sizes_(static_cast<std::size_t>(blocks_)) {}

    int count() const { return blocks_; }
    // Compresses the blocks handed out in turn by `next` until none is left; false when zlib
    // failed (the others then stop too). Each thread gives its own scratch buffers.
    bool compress(std::atomic<int>& next, std::atomic<bool>& failed) {
        std::vector<unsigned char> raw(row_bytes_ * block_lines_), filtered(raw.size());
        for (int b; (b = next.fetch_add(1)) < blocks_ && !failed;)
            if (!compress_block(b, raw.data(), filtered.data())) return false;
        return true;
    }
    // The line offset table after `head`, then the header, table and blocks in gathered writes.
    void write(File& file, std::vector<char>& head) const {
        std::uint64_t offset = head.size() + static_cast<std::size_t>(blocks_) * 8;
        for (std::size_t size : sizes_) {
            put_bytes(head, &offset, 8);
            offset += 8 + size;
        }
        std::vector<iovec> pieces;
        pieces.reserve(static_cast<std::size_t>(blocks_) + 1);
        pieces.push_back({head.data(), head.size()});
        for (int b = 0; b < blocks_; ++b)
            pieces.push_back({out_.get() + slot_ * static_cast<std::size_t>(b), 8 + sizes_[b]});
        file.writev(pieces);
    }

private:
    bool compress_block(int b, unsigned char* raw, unsigned char* filtered) {
        const int y0 = b * block_lines_, y1 = std::min(h_, y0 + block_lines_);
        const std::size_t n = row_bytes_ * static_cast<std::size_t>(y1 - y0);
        put_lines(reinterpret_cast<char*>(raw), channels_, w_, y0, y1);
        reorder_and_predict(raw, n, filtered);
        char* dst = out_.get() + slot_ * static_cast<std::size_t>(b);
        unsigned char* data = reinterpret_cast<unsigned char*>(dst + 8);
        std::size_t size = 0;
        if (compression_ == ExrCompression::rle) {
            size = rle_encode(filtered, n, data);
        } else {
            uLongf len = static_cast<uLongf>(n - 1);  // room for less than the raw block
            const int rc = compress2(data, &len, filtered, static_cast<uLong>(n), 1);
            if (rc == Z_OK)
                size = len;
            else if (rc != Z_BUF_ERROR)
                return false;
        }
        if (size == 0) {  // not smaller: the raw block, its size telling readers so
            std::memcpy(data, raw, n);
            size = n;
        }
        const std::int32_t header_words[2] = {y0, static_cast<std::int32_t>(size)};
        std::memcpy(dst, header_words, 8);
        sizes_[static_cast<std::size_t>(b)] = size;
        return true;
    }

    Channels channels_;
    int w_, h_;
    ExrCompression compression_;
    std::size_t row_bytes_;
    int block_lines_, blocks_;
    std::size_t slot_;
    std::unique_ptr<char[]> out_;
    std::vector<std::size_t> sizes_;  // data bytes per block
};

// Compressed on every core, blocks handed out in turn; throws naming the path if zlib failed.
void compress_on_threads(CompressedBlocks& blocks, int threads, const std::string& path) {
    std::atomic<int> next{0};
    std::atomic<bool> failed{false};
    auto work = [&] {  // nothing may escape a thread: a failure is reported after the join
        try {
            if (!blocks.compress(next, failed)) failed = true;
        } catch (...) {
            failed = true;
        }
    };
    if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    threads = std::min(blocks.count(), threads);
    run_workers(threads, [&](int) { work(); });
    if (failed) throw std::runtime_error(path + ": compressing the EXR blocks failed");
}

}  // namespace

void write_exr_scanlines(const std::string& path, const RenderedImage& image,
                         const std::map<std::string, std::string>& attributes,
                         ExrCompression compression, int threads, ExrChannels channels) {
    check_has_planes(path, image, channels);
    std::vector<char> head =
        exr_header(image.width, image.height, attributes, compression, channels);
    File file(path);
    if (compression == ExrCompression::none) {
        write_uncompressed(file, head, image, channels);
    } else {
        // The sizes of the compressed blocks give the line offset table.
        CompressedBlocks blocks(channels_of(frame_pixels(image, 0), channels), image.width,
                                image.height, compression);
        compress_on_threads(blocks, threads, path);
        blocks.write(file, head);
    }
    file.close();
}

}  // namespace rt
