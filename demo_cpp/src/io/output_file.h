// An output written under a temporary name beside its target and renamed onto it when
// finished, so that a failed write never leaves a partial file.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <string>

namespace rt {

// Writes all n bytes to fd at `offset` (pwrite), or at the file's position when `offset` is
// negative (write), resuming after a short write or a signal. Returns 0, or the errno of the
// failure (EIO for a write that wrote nothing).
int write_fully(int fd, const void* data, std::size_t n, off_t offset = -1) noexcept;

class AtomicFile {
public:
    explicit AtomicFile(std::string path);
    ~AtomicFile();  // removes the temporary file unless committed
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;
    const std::string& path() const { return path_; }
    const std::string& temp() const { return temp_; }
    // Creates the temporary file for writing: a new regular file, never anything already at its
    // name (a FIFO planted there would block the writer). Throws OutputError naming the path.
    int create();
    // Renames the temporary onto the target; throws OutputError (image_io.h) naming the path.
    void commit();

private:
    std::string path_, temp_;
    bool committed_ = false;
};

}  // namespace rt
