#include <algorithm>
#include <optional>

#include <unistd.h>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <fmt/format.h>

#include <plx/core/memory.h>
#include <plx/core/parallel.h>

namespace plx {

struct ThreadPool::Impl {
    // The arena is left to be initialised by its first use: initialised here, it makes the
    // reprojection step of a stereo pair (whose renderers hold several pools) 10-15% slower on
    // two cores (BM_SecondEyeMethods).
    explicit Impl(int threads) : arena(threads) {
        // TBB's workers number one less than the cores unless a control raises the limit; an
        // arena asking for more gets the cores only, and TBB says so on stderr. A pool asked for
        // more threads than cores (a scaling run, a comparison at a fixed count) gets them: the
        // control lasts as long as the pool. While pools of several such sizes live, TBB takes
        // the smallest limit.
        if (threads > tbb::info::default_concurrency())
            moreThreadsThanCores.emplace(tbb::global_control::max_allowed_parallelism,
                                         size_t(threads));
    }
    tbb::task_arena arena;
    std::optional<tbb::global_control> moreThreadsThanCores;
};

Status checkThreadCount(int threads, std::string_view what) {
    if (threads < 0 || threads > kMaxThreads)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("{} {} outside 0 .. {}", what, threads, kMaxThreads));
    const std::optional<uint64_t> room = addressSpaceRemaining();
    if (!room) return Status::ok();
    // What the threads reserve as they start: TBB's stack for each worker (the calling thread
    // runs in the arena too), and the 64 MiB heap glibc maps for each thread that allocates, up
    // to its default of eight such arenas a core besides the main one. A render's VmPeak follows
    // this within 3% from 2 to 64 threads.
    const int count = threads == 0 ? tbb::info::default_concurrency() : threads;
    const long cores = std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
    const double stack =
        double(tbb::global_control::active_value(tbb::global_control::thread_stack_size));
    constexpr double kArenaBytes = double(64 << 20);
    const double reserved =
        double(count - 1) * stack + double(std::min<long>(count, 8 * cores) - 1) * kArenaBytes;
    constexpr double kGiB = double(1 << 30);
    if (reserved > double(*room))
        return errorStatus(
            ErrorCode::kOutOfRange,
            fmt::format("{} {}{}: the threads reserve about {:.2f} GiB of address space (stacks "
                        "and malloc arenas), {:.2f} GiB is left under its limit (ulimit -v)",
                        what, threads,
                        threads == 0 ? fmt::format(" ({} threads, all cores)", count) : "",
                        reserved / kGiB, double(*room) / kGiB));
    return Status::ok();
}

ThreadPool::ThreadPool(int threads) {
    int hw = tbb::info::default_concurrency();
    mThreads = threads <= 0 ? hw : threads;
    mImpl = std::make_unique<Impl>(mThreads);
}

ThreadPool::~ThreadPool() = default;

void ThreadPool::parallelFor(size_t count, size_t grain,
                             const std::function<void(size_t, size_t)>& body) {
    if (count == 0) return;
    if (mThreads == 1 || count <= grain) {
        body(0, count);
        return;
    }
    mImpl->arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, count, std::max<size_t>(grain, 1)),
                          [&](const tbb::blocked_range<size_t>& r) { body(r.begin(), r.end()); });
    });
}

void ThreadPool::run(const std::function<void()>& fn) { mImpl->arena.execute(fn); }

int currentThreadSlot() {
    int slot = tbb::this_task_arena::current_thread_index();
    return slot < 0 ? 0 : slot;
}

}  // namespace plx
