// Outputs written band by band while the frame renders (BandSink): rtdemo render with a PPM or
// an uncompressed EXR as its only output. Each band goes to its place in the file at once
// (pwrite) from the thread that traced it, so no frame is kept, no frame-sized memory is
// zero-filled by the kernel, and the encoding runs on every render thread. The
// files are byte for byte what write_ppm and write_exr write, but for the EXR's padding
// attribute (below). A stream writes a file without a name (O_TMPFILE) that finish() names and
// renames onto the target: one never finished, or a process killed, leaves nothing behind.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <string>

#include "core/band_sink.h"
#include "io/image_io.h"
#include "io/output_file.h"

namespace rt {

// The temporary file both streams write at offsets; the first failed write is kept.
class BandFile {
public:
    explicit BandFile(const std::string& path);  // throws OutputError naming the path
    ~BandFile();
    BandFile(const BandFile&) = delete;
    BandFile& operator=(const BandFile&) = delete;
    // The file's whole size at once (before any band): ext4 then maps each band's pages
    // without allocating as it goes (9.8 MB: 1.4 ms instead of 1.9, bench/NOTES.md), and a full
    // disk or a file-size limit fails here, before the render. Throws OutputError naming the
    // path; a file system that cannot allocate ahead just writes as it goes.
    void allocate(std::size_t size);
    void write_at(const void* data, std::size_t n, std::size_t offset) noexcept;
    void fail(int error) noexcept;  // a failure other than a write (kept unless one was)
    const std::string& path() const { return file_.path(); }
    // Times a band's encoding and writing (construct at the start of BandSink::band).
    class Busy {
    public:
        explicit Busy(BandFile& file) : file_(file), start_(std::chrono::steady_clock::now()) {}
        ~Busy() {
            file_.busy_ns_ += std::chrono::duration_cast<std::chrono::nanoseconds>(
                                  std::chrono::steady_clock::now() - start_)
                                  .count();
        }

    private:
        BandFile& file_;
        std::chrono::steady_clock::time_point start_;
    };
    // The render threads' time in encoding and writing bands, summed over the threads.
    double busy_seconds() const { return static_cast<double>(busy_ns_.load()) * 1e-9; }
    // Throws OutputError naming the path if any write failed; else closes and renames.
    void finish();

private:
    AtomicFile file_;
    int fd_ = -1;
    bool named_ = false;         // the file has its temporary name (else it has none yet)
    std::atomic<int> error_{0};  // errno of the first failure
    std::atomic<std::int64_t> busy_ns_{0};
};

class PpmStream final : public BandSink {
public:
    PpmStream(const std::string& path, int width, int height, PpmRounding rounding);
    std::optional<PpmRounding> rgb8() const override { return rounding_; }
    void band(int y0, int rows, int width, const BandPixels& pixels) noexcept override;
    void finish() { file_.finish(); }
    double write_seconds() const { return file_.busy_seconds(); }  // summed over the threads

private:
    BandFile file_;
    std::size_t header_ = 0;
    PpmRounding rounding_;
};

// The header comes last, when the attributes that are only known after rendering (its time,
// the ray counts) are: `provisional` is the header's map with every such value present (any
// value), and room is kept for values up to kSlack bytes longer in all. The attribute
// "rtval.padding" (spaces) fills what the final values leave of that room.
class ExrStream final : public BandSink {
public:
    static constexpr std::size_t kSlack = 256;
    ExrStream(const std::string& path, int width, int height,
              const std::map<std::string, std::string>& provisional,
              ExrChannels channels = ExrChannels::all);
    // Planes: each line's block is then each channel's row, copied whole.
    int step() const override { return 1; }
    void band(int y0, int rows, int width, const BandPixels& pixels) noexcept override;
    // Writes the header with `attributes` and the line offset table, then renames the file.
    void finish(const std::map<std::string, std::string>& attributes);
    double write_seconds() const { return file_.busy_seconds(); }  // summed over the threads

private:
    // The header with `attributes` and `padding` spaces of rtval.padding.
    std::vector<char> header(const std::map<std::string, std::string>& attributes,
                             std::size_t padding) const;
    BandFile file_;
    int width_, height_;
    ExrChannels channels_;
    std::size_t header_room_ = 0;
};

}  // namespace rt
