#include "core/worker_threads.h"

#include <gtest/gtest.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace rt {
namespace {

TEST(WorkerThreads, EveryIndexRunsExactlyOnce) {
    for (int count : {1, 2, 3, 8, 70}) {
        std::vector<std::atomic<int>> runs(static_cast<std::size_t>(count));
        run_workers(count, [&](int i) { ++runs[static_cast<std::size_t>(i)]; });
        for (int i = 0; i < count; ++i)
            EXPECT_EQ(runs[static_cast<std::size_t>(i)].load(), 1)
                << "index " << i << " of " << count;
    }
}

TEST(WorkerThreads, IndexZeroRunsOnTheCallerAndTheOthersAtTheSameTime) {
    const std::thread::id caller = std::this_thread::get_id();
    std::atomic<int> arrived{0};
    std::atomic<bool> all_met{true};
    std::thread::id zero;
    run_workers(4, [&](int i) {
        if (i == 0) zero = std::this_thread::get_id();
        ++arrived;
        // Each waits for all four: were any index run after another had returned, this would
        // time out.
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (arrived.load() < 4)
            if (std::chrono::steady_clock::now() > until) {
                all_met = false;
                return;
            }
    });
    EXPECT_EQ(zero, caller);
    EXPECT_TRUE(all_met.load());
}

// A throwing index: the others still run to their end before the first exception (the
// caller's, when it threw too) comes out of run_workers.
TEST(WorkerThreads, AnExceptionComesOutAfterEveryThreadHasFinished) {
    for (int thrower : {0, 2}) {
        std::atomic<int> finished{0};
        try {
            run_workers(4, [&](int i) {
                if (i == thrower) throw std::runtime_error("index " + std::to_string(i));
                std::this_thread::sleep_for(std::chrono::milliseconds(30));
                ++finished;
            });
            ADD_FAILURE() << "no exception from index " << thrower;
        } catch (const std::runtime_error& e) {
            EXPECT_EQ(std::string(e.what()), "index " + std::to_string(thrower));
        }
        EXPECT_EQ(finished.load(), 3) << "thrower " << thrower;
    }
    try {
        run_workers(3, [](int i) { throw std::runtime_error("index " + std::to_string(i)); });
        ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), "index 0");
    }
}

// The start on one CPU is a hint: once running, each thread may use every CPU the caller may.
TEST(WorkerThreads, StartedThreadsKeepTheCallersCpus) {
    cpu_set_t caller;
    ASSERT_EQ(sched_getaffinity(0, sizeof caller, &caller), 0);
    std::mutex m;
    std::vector<cpu_set_t> seen;
    run_workers(3, [&](int) {
        cpu_set_t mine;
        ASSERT_EQ(sched_getaffinity(0, sizeof mine, &mine), 0);
        const std::lock_guard<std::mutex> lock(m);
        seen.push_back(mine);
    });
    ASSERT_EQ(seen.size(), 3u);
    for (const cpu_set_t& s : seen) EXPECT_TRUE(CPU_EQUAL(&s, &caller));
}

}  // namespace
}  // namespace rt
