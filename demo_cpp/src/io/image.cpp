#include "io/image.h"

#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <utility>

namespace rt {

namespace {

constexpr std::size_t kHugePage = std::size_t{2} << 20;
// Below this a plane comes from the heap: a mapping of its own would cost more than it saves.
constexpr std::size_t kMapFrom = std::size_t{1} << 20;

}  // namespace

Plane::Plane(std::size_t n, float value) : size_(n) {
    if (n == 0) return;
    if (n > (SIZE_MAX - 2 * kHugePage) / sizeof(float)) throw std::bad_alloc();
    const std::size_t bytes = n * sizeof(float);
    if (bytes >= kMapFrom) {
        // Mapped with a huge page of slack, then trimmed to start on a huge-page boundary, so
        // that every whole 2 MB of the plane can be one huge page.
        const std::size_t want = (bytes + kHugePage - 1) / kHugePage * kHugePage;
        void* p = ::mmap(nullptr, want + kHugePage, PROT_READ | PROT_WRITE,
                         MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (p == MAP_FAILED) throw std::bad_alloc();
        const auto start = reinterpret_cast<std::uintptr_t>(p);
        const std::uintptr_t aligned = (start + kHugePage - 1) & ~(kHugePage - 1);
        if (aligned > start) ::munmap(p, aligned - start);
        const std::uintptr_t tail = aligned + want;
        const std::uintptr_t end = start + want + kHugePage;
        if (end > tail) ::munmap(reinterpret_cast<void*>(tail), end - tail);
        ::madvise(reinterpret_cast<void*>(aligned), want, MADV_HUGEPAGE);
        data_ = reinterpret_cast<float*>(aligned);
        mapped_ = want;
    } else {
        data_ = static_cast<float*>(std::calloc(n, sizeof(float)));
        if (!data_) throw std::bad_alloc();
    }
    if (value != 0.0f || std::signbit(value)) std::fill(data_, data_ + n, value);
}

Plane::Plane(const Plane& other) : Plane(other.size_) {
    if (size_) std::memcpy(data_, other.data_, size_ * sizeof(float));
}

Plane::Plane(Plane&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      mapped_(std::exchange(other.mapped_, 0)) {}

Plane& Plane::operator=(Plane other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    std::swap(mapped_, other.mapped_);
    return *this;
}

Plane::~Plane() {
    if (mapped_)
        ::munmap(data_, mapped_);
    else
        std::free(data_);
}

bool operator==(const Plane& a, const Plane& b) {
    if (a.size_ != b.size_) return false;
    for (std::size_t i = 0; i < a.size_; ++i)
        if (!(a.data_[i] == b.data_[i])) return false;
    return true;
}

}  // namespace rt
