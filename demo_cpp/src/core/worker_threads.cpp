#include "core/worker_threads.h"

#include <pthread.h>
#include <sched.h>

#include <exception>
#include <vector>

namespace rt {
namespace {

struct Start {
    const std::function<void(int)>* work;
    int index;
    bool widen;         // the thread was started on one CPU: give it back the caller's set
    cpu_set_t allowed;  // the caller's CPUs
    std::exception_ptr error;
};

void* run_one(void* arg) {
    Start& start = *static_cast<Start*>(arg);
    // Already on its CPU: widening the set moves nothing now, and lets the scheduler move the
    // thread later if that CPU gets busy. A failure leaves it where it is: still correct.
    if (start.widen) pthread_setaffinity_np(pthread_self(), sizeof start.allowed, &start.allowed);
    try {
        (*start.work)(start.index);
    } catch (...) {
        start.error = std::current_exception();  // rethrown by run_workers after the join
    }
    return nullptr;
}

// The CPUs to start threads 1, 2, … on: the caller's other CPUs first, then its own.
std::vector<int> start_cpus(const cpu_set_t& allowed) {
    const int own = sched_getcpu();
    std::vector<int> cpus;
    for (int c = 0; c < CPU_SETSIZE; ++c)
        if (CPU_ISSET(c, &allowed) && c != own) cpus.push_back(c);
    if (cpus.empty()) return cpus;  // one CPU: nowhere else to start
    if (own >= 0 && CPU_ISSET(own, &allowed)) cpus.push_back(own);
    return cpus;
}

}  // namespace

void run_workers(int count, const std::function<void(int)>& work) {
    if (count <= 1) {
        work(0);
        return;
    }
    cpu_set_t allowed;
    CPU_ZERO(&allowed);
    const bool known = sched_getaffinity(0, sizeof allowed, &allowed) == 0;
    const std::vector<int> cpus = known ? start_cpus(allowed) : std::vector<int>{};

    // Everything the threads use, and the lists, allocated before the first thread starts:
    // nothing below may throw while a thread is running.
    std::vector<Start> starts(static_cast<std::size_t>(count));
    std::vector<pthread_t> threads;
    std::vector<int> not_started;
    threads.reserve(static_cast<std::size_t>(count));
    not_started.reserve(static_cast<std::size_t>(count));
    for (int i = 1; i < count; ++i) {
        Start& s = starts[static_cast<std::size_t>(i)];
        s = Start{&work, i, !cpus.empty(), allowed, nullptr};
        pthread_t thread;
        int err = -1;
        pthread_attr_t attr;
        if (s.widen && pthread_attr_init(&attr) == 0) {
            cpu_set_t one;
            CPU_ZERO(&one);
            CPU_SET(cpus[static_cast<std::size_t>(i - 1) % cpus.size()], &one);
            if (pthread_attr_setaffinity_np(&attr, sizeof one, &one) == 0)
                err = pthread_create(&thread, &attr, run_one, &s);
            pthread_attr_destroy(&attr);
        }
        if (err != 0) {  // one CPU only, or that CPU refused (a cpuset changed): start anywhere
            s.widen = false;
            err = pthread_create(&thread, nullptr, run_one, &s);
        }
        if (err == 0)
            threads.push_back(thread);
        else
            not_started.push_back(i);
    }
    std::exception_ptr error;
    try {
        work(0);
        for (int i : not_started) work(i);
    } catch (...) {
        error = std::current_exception();
    }
    for (pthread_t t : threads) pthread_join(t, nullptr);
    for (const Start& s : starts)
        if (!error && s.error) error = s.error;
    if (error) std::rethrow_exception(error);
}

}  // namespace rt
