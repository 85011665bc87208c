#include "io/output_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

#include "io/image_io.h"

namespace rt {

int write_fully(int fd, const void* data, std::size_t n, off_t offset) noexcept {
    const char* p = static_cast<const char*>(data);
    while (n > 0) {
        const ssize_t done = offset < 0 ? ::write(fd, p, n) : ::pwrite(fd, p, n, offset);
        if (done < 0 && errno == EINTR) continue;
        if (done <= 0) return done < 0 ? errno : EIO;
        p += done;
        n -= static_cast<std::size_t>(done);
        if (offset >= 0) offset += done;
    }
    return 0;
}

AtomicFile::AtomicFile(std::string path)
    : path_(std::move(path)), temp_(path_ + ".tmp" + std::to_string(::getpid())) {}

AtomicFile::~AtomicFile() {
    if (!committed_) {
        std::error_code ec;
        std::filesystem::remove(temp_, ec);
    }
}

int AtomicFile::create() {
    const int fd =
        ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0666);
    if (fd < 0)
        throw OutputError(path_ + ": cannot create the temporary file " + temp_ + ": " +
                          std::strerror(errno));
    return fd;
}

void AtomicFile::commit() {
    check_writable(path_);  // again: the target may have changed while we wrote
    std::error_code ec;
    std::filesystem::rename(temp_, path_, ec);
    if (ec) throw OutputError(path_ + ": cannot write: " + ec.message());
    committed_ = true;
}

}  // namespace rt
