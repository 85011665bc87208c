#include "io/file_kind.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace rt {

std::string describe_file_type(unsigned mode) {
    if (S_ISFIFO(mode)) return "a FIFO";
    if (S_ISSOCK(mode)) return "a socket";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISDIR(mode)) return "a folder";
    if (S_ISLNK(mode)) return "a symbolic link";
    if (S_ISREG(mode)) return "a regular file";
    return "not a regular file";
}

namespace {

struct Fd {
    int fd;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

}  // namespace

std::string read_regular_file(const std::string& path, std::size_t max_bytes) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0)
        throw FileKindError(path + ": cannot open: " + std::strerror(errno));
    if (!S_ISREG(st.st_mode))
        throw FileKindError(path + ": is " + describe_file_type(st.st_mode) +
                            ", not a regular file");
    const Fd f{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
    if (f.fd < 0) throw FileKindError(path + ": cannot open: " + std::strerror(errno));
    if (::fstat(f.fd, &st) != 0 || !S_ISREG(st.st_mode))  // swapped after the check
        throw FileKindError(path + ": is " + describe_file_type(st.st_mode) +
                            ", not a regular file");
    std::string data;
    char buf[1 << 16];
    for (;;) {
        const ssize_t n = ::read(f.fd, buf, sizeof buf);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw FileKindError(path + ": cannot read: " + std::strerror(errno));
        }
        if (n == 0) break;
        data.append(buf, static_cast<std::size_t>(n));
        if (data.size() > max_bytes)
            throw FileKindError(path + ": more than the " + std::to_string(max_bytes) +
                                " bytes allowed");
    }
    return data;
}

void check_replaceable(const std::string& path) {
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) return;  // missing: nothing is replaced
    if (!S_ISREG(st.st_mode))
        throw FileKindError(path + ": is " + describe_file_type(st.st_mode) +
                            "; outputs only ever replace regular files");
}

bool same_file(const std::string& a, const std::string& b) {
    struct stat sa {
    }, sb{};
    if (::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    // Not both there yet: compare absolute, normalised paths ("./x.exr" is "x.exr").
    const auto normal = [](const std::string& p) {
        std::error_code ec;
        auto abs = std::filesystem::absolute(p, ec);
        auto canon = std::filesystem::weakly_canonical(abs, ec);
        return (ec ? abs : canon).lexically_normal();
    };
    return normal(a) == normal(b);
}

}  // namespace rt
