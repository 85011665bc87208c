#include "output_file.h"

#include <unistd.h>

#include <filesystem>
#include <system_error>
#include <utility>

#include "image_io.h"

namespace rt {

AtomicFile::AtomicFile(std::string path)
    : path_(std::move(path)), temp_(path_ + ".tmp" + std::to_string(::getpid())) {}

AtomicFile::~AtomicFile() {
    if (!committed_) {
        std::error_code ec;
        std::filesystem::remove(temp_, ec);
    }
}

void AtomicFile::commit() {
    check_writable(path_);  // again: the target may have changed while we wrote
    std::error_code ec;
    std::filesystem::rename(temp_, path_, ec);
    if (ec) throw OutputError(path_ + ": cannot write: " + ec.message());
    committed_ = true;
}

}  // namespace rt
