#pragma once
// Parallel helpers on oneTBB. Work runs inside a ThreadPool's arena so a caller can bound the
// number of threads (the CLI's --threads, the 2-thread comparisons against llvmpipe).

#include <cstddef>
#include <functional>
#include <memory>
#include <string_view>

#include <plx/core/status.h>

namespace plx {

// The most threads a pool, renderer or warper may be asked for.
constexpr int kMaxThreads = 1024;

// Whether `threads` (0: all cores) may be asked for: within [0, kMaxThreads] and, where the
// address space is limited (ulimit -v), with room left for what the threads reserve as they
// start (stacks and malloc arenas). A TBB worker that cannot start ends the process, so a count
// too large for the limit is refused here, before any starts. `what` names the count in the
// error ("--threads", "render threads").
Status checkThreadCount(int threads, std::string_view what);

class ThreadPool {
public:
    // threads <= 0 means all hardware threads.
    explicit ThreadPool(int threads = 0);
    ~ThreadPool();
    ThreadPool(const ThreadPool&) = delete;
    ThreadPool& operator=(const ThreadPool&) = delete;

    int threadCount() const { return mThreads; }

    // Calls body(begin, end) over [0, count) split into ranges of about `grain` items, in
    // parallel, and returns when all are done. body must be safe to call concurrently.
    void parallelFor(size_t count, size_t grain,
                     const std::function<void(size_t begin, size_t end)>& body);

    // Runs fn inside this pool's arena (nested TBB calls then use at most threadCount threads).
    void run(const std::function<void()>& fn);

private:
    struct Impl;
    std::unique_ptr<Impl> mImpl;
    int mThreads = 1;
};

// Index of the calling thread inside the current arena, in [0, threadCount); for per-thread
// scratch buffers.
int currentThreadSlot();

}  // namespace plx
