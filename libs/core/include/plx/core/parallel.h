#pragma once
// Parallel helpers on oneTBB. Work runs inside a ThreadPool's arena so a caller can bound the
// number of threads (the CLI's --threads, the 2-thread comparisons against llvmpipe).

#include <cstddef>
#include <functional>
#include <memory>

namespace plx {

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
