// What a path is, before rtdemo reads or replaces it: inputs come only from regular files
// (a FIFO would block, /dev/zero never ends), outputs only ever replace regular files
// (renaming over /dev/full would turn the device into a file). Mirrors compare/safe_paths.py.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace rt {

class FileKindError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// "a FIFO", "a character device", "a folder", ... for a st_mode.
std::string describe_file_type(unsigned mode);

// The bytes of the regular file `path` (symlinks followed), at most `max_bytes`. Opened
// non-blocking and checked after opening, so a FIFO never blocks. Throws FileKindError
// "PATH: is a FIFO, not a regular file" and the like.
std::string read_regular_file(const std::string& path, std::size_t max_bytes);

// Throws FileKindError when `path` exists and is not a regular file (a symlink included:
// the rename would cut it, not write through it). A missing path is fine.
void check_replaceable(const std::string& path);

// Whether two paths name one file: same device and inode when both exist, else the same
// absolute, normalised path.
bool same_file(const std::string& a, const std::string& b);

}  // namespace rt
