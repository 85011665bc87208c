#pragma once

#include <functional>

namespace rt {

// Runs work(0) … work(count − 1) at once and returns when all have returned: index 0 on the
// calling thread, each other index on a new thread. `work` must not throw.
//
// Each new thread is started on a CPU other than the caller's, the CPUs taken in turn, and is
// free to move as soon as it runs. Left to itself, Linux queued the second thread of a 10 ms
// render behind its parent on the same CPU while the other CPU idled, and the two took turns
// for up to 10 ms until the load balancer moved one (perf sched, bench/NOTES.md).
//
// An index whose thread cannot be started (no memory, a thread limit) runs on the calling
// thread after its own, so every index runs exactly once.
void run_workers(int count, const std::function<void(int)>& work);

}  // namespace rt
