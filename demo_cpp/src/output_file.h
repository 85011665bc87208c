// An output written under a temporary name beside its target and renamed onto it when
// finished, so that a failed write never leaves a partial file.
#pragma once

#include <string>

namespace rt {

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
