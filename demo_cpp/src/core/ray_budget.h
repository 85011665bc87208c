// A render's ray budget (rtdemo render --ray-budget N): the rays its workers trace, counted as
// the EXR header counts them (camera, secondary and shadow rays), so that a render whose tree
// of rays explodes stops instead of running away. Each worker counts its own rays as it always
// does and charges them to one shared counter only every kRayBudgetGrain rays (the tracing
// loops stay as fast); once the counter has passed the budget, every worker stops at its next
// charge and the render throws RayBudgetExhausted after they have all returned.
#pragma once

#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace rt {

// Rays a worker traces between two charges: well under a millisecond of tracing, so a render
// stops within about a millisecond per thread of passing its budget.
constexpr std::uint64_t kRayBudgetGrain = 1u << 16;

class RayBudgetExhausted : public std::runtime_error {
public:
    RayBudgetExhausted(std::uint64_t budget, std::uint64_t traced)
        : std::runtime_error("ray budget of " + std::to_string(budget) + " rays exhausted after " +
                             std::to_string(traced) +
                             " rays (camera, secondary and shadow rays); no output written"),
          budget_(budget),
          traced_(traced) {}
    std::uint64_t budget() const { return budget_; }
    std::uint64_t traced() const { return traced_; }

private:
    std::uint64_t budget_, traced_;
};

class RayBudget {
public:
    explicit RayBudget(std::uint64_t limit) : limit_(limit) {}
    // Adds n rays traced; false once the total has passed the limit (from then on).
    bool charge(std::uint64_t n) {
        if (used_.fetch_add(n, std::memory_order_relaxed) + n > limit_)
            exhausted_.store(true, std::memory_order_relaxed);
        return !exhausted_.load(std::memory_order_relaxed);
    }
    // Takes back n rays charged for work that is done again and counted again (the packet
    // engine's tile traced again pixel by pixel): the charged total stays the frame's count.
    void refund(std::uint64_t n) { used_.fetch_sub(n, std::memory_order_relaxed); }
    // After the workers have returned: throws RayBudgetExhausted once the limit was passed.
    void check() const {
        if (exhausted_.load(std::memory_order_relaxed))
            throw RayBudgetExhausted(limit_, used_.load(std::memory_order_relaxed));
    }

private:
    alignas(64) std::atomic<std::uint64_t> used_{0};
    std::atomic<bool> exhausted_{false};
    std::uint64_t limit_;
};

// One worker's side of a budget: what it has charged so far, and whether it must stop.
struct BudgetShare {
    RayBudget* budget = nullptr;  // none: no limit
    std::uint64_t charged = 0;
    bool stopped = false;
    // The worker's count of rays is now `traced`: charges what is new once it is a grain (or
    // everything, `settle`, at the worker's end). Returns whether the worker must stop.
    bool update(std::uint64_t traced, bool settle = false) {
        if (!budget || stopped || traced - charged < (settle ? 1 : kRayBudgetGrain)) return stopped;
        stopped = !budget->charge(traced - charged);
        charged = traced;
        return stopped;
    }
};

}  // namespace rt
