#pragma once

#include <functional>

namespace rt {

// Runs work(0) … work(count − 1) at once and returns when all have returned: index 0 on the
// calling thread, each other index on a new thread.
//
// Each new thread is started on one of the caller's CPUs, the others before the caller's own,
// taken in turn, and is free to move as soon as it runs (its CPU set widened back to the
// caller's; should that fail, it stays where it started). Left to itself, Linux queued the
// second thread of a 10 ms render behind its parent on the same CPU while the other CPU idled,
// and the two took turns for up to 10 ms until the load balancer moved one (perf sched,
// bench/NOTES.md).
//
// An index whose thread cannot be started (no memory, a thread limit) runs on the calling
// thread after its own, so every index runs once. If any index throws, run_workers still waits
// for every thread, then rethrows the first exception (the calling thread's first).
void run_workers(int count, const std::function<void(int)>& work);

}  // namespace rt
