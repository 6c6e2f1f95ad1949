// Isolated import: the file is parsed by importFile in a forked child process under resource
// limits, and the scene comes back over a pipe in the checked wire form (scene_wire.h).
//
// Why fork and not posix_spawn of a helper binary: the library has no binary of its own to
// spawn, and a server linking it must get the same protection as the CLI. The child calls no
// code of the caller's, only the import (which starts no threads), then leaves with _exit so
// that the caller's atexit handlers and stdio buffers are not run twice. A lock another thread
// of the caller held at fork time could block the child; the parent's deadline turns that into
// a timeout message, never a hang.

#include <plx/scene/import.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <new>
#include <optional>
#include <span>
#include <vector>

#include <fcntl.h>
#include <malloc.h>
#include <poll.h>
#include <pthread.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/uio.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include <plx/core/memory.h>

#include "import_unfinalized.h"
#include "scene_wire.h"

namespace plx::scene {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kChildFd = 3;  // the pipe's write end in the child; every other fd is closed

bool writeAll(int fd, const void* p, size_t n) {
    auto* bytes = static_cast<const uint8_t*>(p);
    while (n > 0) {
        ssize_t k = ::write(fd, bytes, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return false;
        bytes += k;
        n -= size_t(k);
    }
    return true;
}

// Hands n bytes to the pipe by reference (vmsplice): the kernel queues the pages themselves
// instead of copying them into pipe pages, so a 24 MB scene is copied once (into the parent),
// not twice. Sound only because the pages are never written again: the child exits as soon as
// the scene is sent, without running a destructor (childImport). Falls back to write.
bool spliceAll(int fd, const void* p, size_t n) {
    auto* bytes = static_cast<const uint8_t*>(p);
    while (n > 0) {
        iovec iov{const_cast<uint8_t*>(bytes), n};
        ssize_t k = ::vmsplice(fd, &iov, 1, 0);
        if (k < 0 && errno == EINTR) continue;
        if (k < 0 && (errno == EINVAL || errno == ENOSYS)) return writeAll(fd, bytes, n);
        if (k <= 0) return false;
        bytes += k;
        n -= size_t(k);
    }
    return true;
}

// Gathers small fields into one buffer; large arrays go to the pipe directly, by reference.
class PipeSink {
public:
    explicit PipeSink(int fd) : mFd(fd) { mBuffer.reserve(kBufferBytes); }
    bool put(const void* p, size_t n) {
        if (mBuffer.size() + n > kBufferBytes && !flush()) return false;
        if (n >= kBufferBytes) return spliceAll(mFd, p, n);
        auto* bytes = static_cast<const uint8_t*>(p);
        mBuffer.insert(mBuffer.end(), bytes, bytes + n);
        return true;
    }
    bool flush() {
        bool ok = writeAll(mFd, mBuffer.data(), mBuffer.size());
        mBuffer.clear();
        return ok;
    }

private:
    static constexpr size_t kBufferBytes = size_t(1) << 16;
    int mFd;
    std::vector<uint8_t> mBuffer;
};

// Recurses until the stack runs out (the test hook's "stack"); the depth check hides the
// recursion from the compiler's infinite-recursion warning.
int stackHog(int depth) {
    volatile char frame[4096];
    frame[0] = char(depth);
    if (depth < INT32_MAX) frame[1] = char(stackHog(depth + 1));
    return frame[0] + frame[1];
}

// Deterministic failures for the tests, read in the child only: PLX_TEST_IMPORT_FAULT=segv,
// abort, spin, alloc, stack or garbage. Unset (always, outside tests) it does nothing.
void testFault(int fd) {
    const char* fault = std::getenv("PLX_TEST_IMPORT_FAULT");
    if (!fault) return;
    std::string f = fault;
    if (f == "segv") std::raise(SIGSEGV);
    if (f == "abort") std::abort();
    if (f == "spin") {
        volatile uint64_t i = 0;
        for (;;) i = i + 1;
    }
    if (f == "alloc") {
        std::vector<std::vector<uint8_t>> hog;
        for (;;) hog.emplace_back(size_t(64) << 20, uint8_t(1));  // touched, so really used
    }
    if (f == "stack") stackHog(0);
    if (f == "garbage") {
        (void)writeAll(fd, "\3\0\0\0\0\0\0\0xyz", 11);  // length 3, then no wire header
        ::_exit(0);
    }
}

bool saysOutOfMemory(const Status& s) {
    return s.message().find("out of memory") != std::string::npos;
}

struct ChildJob {
    const std::string* path;
    ImportOptions options;  // isolation disabled: the child imports in-process
    bool written = false;
};

// Sends one wire message prefixed by its length (u64), counted by a first pass that writes
// nothing, so that the parent allocates its buffer once, at the right size.
bool sendFramed(PipeSink& pipe, const std::function<bool(const wire::Sink&)>& encode) {
    uint64_t length = 0;
    encode([&](const void*, size_t n) { return (length += n), true; });
    wire::Sink sink = [&](const void* p, size_t n) { return pipe.put(p, n); };
    return pipe.put(&length, sizeof length) && encode(sink) && pipe.flush();
}

// The child's import thread: import, then send the scene or the error into the pipe.
void* childImport(void* arg) {
    auto* job = static_cast<ChildJob*>(arg);
    PipeSink pipe(kChildFd);
    auto sendError = [&](wire::WireOutcome outcome, const Status& status) {
        return sendFramed(
            pipe, [&](const wire::Sink& s) { return wire::encodeError(outcome, status, s); });
    };
    try {
        testFault(kChildFd);
        Result<Scene> scene = importFileUnfinalized(*job->path, job->options);
        if (scene) {
            // Leave at once when sent: the parent is still reading the scene's own pages from
            // the pipe (spliceAll), and freeing would write into them. Nothing else is left to
            // do; the process's memory goes with it.
            if (sendFramed(pipe, [&](const wire::Sink& s) { return wire::encodeScene(*scene, s); }))
                ::_exit(0);
        } else {
            job->written =
                sendError(saysOutOfMemory(scene.status()) ? wire::WireOutcome::kOutOfMemory
                                                          : wire::WireOutcome::kError,
                          scene.status());
        }
    } catch (const std::bad_alloc&) {
        job->written = sendError(wire::WireOutcome::kOutOfMemory,
                                 errorStatus(ErrorCode::kOutOfRange, "out of memory"));
    }
    return nullptr;
}

void setLimit(int resource, rlim_t value) {
    rlimit r{value, value};
    if (resource == RLIMIT_CPU) r.rlim_max = value + 1;  // SIGXCPU first, SIGKILL a second later
    (void)::setrlimit(resource, &r);
}

// The child: default crash signals (a sanitizer's or the caller's handlers must not catch the
// parser's crash), no terminal output (a parser's assertion text would break the caller's
// one-line errors), limits, then the import on a thread with the stack the limits give.
[[noreturn]] void runChild(int fd, const std::string& path, const ImportOptions& options,
                           rlim_t addressSpace) {
    for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGXCPU}) std::signal(sig, SIG_DFL);
    if (fd != kChildFd && (::dup2(fd, kChildFd) < 0 || ::close(fd) != 0)) ::_exit(120);
    int devNull = ::open("/dev/null", O_RDWR);
    for (int k = 0; k < 3; ++k) (void)::dup2(devNull, k);
    ::close_range(kChildFd + 1, ~0u, 0);  // another import's pipe must not stay open here
    const IsolationLimits& limits = options.isolation;
    if (addressSpace != 0) setLimit(RLIMIT_AS, addressSpace);
    setLimit(RLIMIT_CPU, rlim_t(std::ceil(std::max(1.0, limits.maxSeconds))));
    setLimit(RLIMIT_CORE, 0);  // a crash is expected here; no core files

    ChildJob job{&path, options};
    job.options.isolation.enabled = false;
    // The import thread allocates from the main arena (brk heap), as an in-process import on
    // the main thread does, not from a fresh per-thread arena of 64 MB mmap'd heaps.
    mallopt(M_ARENA_MAX, 1);
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, std::max<size_t>(limits.maxStackBytes, size_t(1) << 20));
    pthread_t thread;
    if (pthread_create(&thread, &attr, childImport, &job) != 0) ::_exit(121);
    pthread_join(thread, nullptr);
    ::_exit(job.written ? 0 : 122);
}

// The caller's mapped bytes now (VmSize): the child's address-space limit is this plus the
// memory limit, so that a caller already mapping gigabytes (thread stacks, a sanitizer's
// shadow) still leaves the import its full allowance. 0 when unknown: no address-space limit.
rlim_t addressSpaceFor(const IsolationLimits& limits) {
    const uint64_t mapped = mappedBytes();
    if (mapped == 0) return 0;
    return rlim_t(mapped) + limits.maxMemoryBytes + limits.maxStackBytes;
}

enum class ReadEnd { kEof, kDeadline, kTooLarge, kError };

// Waits until fd is readable (bytes or EOF): nothing then, else kDeadline or kError.
std::optional<ReadEnd> waitReadable(int fd, Clock::time_point deadline) {
    for (;;) {
        auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
        if (left.count() <= 0) return ReadEnd::kDeadline;
        pollfd p{fd, POLLIN, 0};
        int ready = ::poll(&p, 1, int(std::min<int64_t>(left.count(), 1000)));
        if (ready > 0) return std::nullopt;
        if (ready < 0 && errno != EINTR) return ReadEnd::kError;
    }
}

// After the whole message: EOF (the child closed the pipe) by the deadline; more bytes are an
// error.
ReadEnd awaitEof(int fd, Clock::time_point deadline) {
    for (;;) {
        if (auto failed = waitReadable(fd, deadline)) return *failed;
        uint8_t extra = 0;
        ssize_t n = ::read(fd, &extra, 1);
        if (n == 0) return ReadEnd::kEof;
        if (n > 0 || (errno != EINTR && errno != EAGAIN)) return ReadEnd::kError;
    }
}

// The parent's copy of the child's message: anonymous memory reserved for the declared length
// without committing it (pages are committed as the child's bytes arrive, so a length alone
// costs nothing), in transparent huge pages where the system allows: a 24 MB scene then takes a
// dozen page faults instead of 6,000, and no zero-filling pass of its own.
class MessageBuffer {
public:
    MessageBuffer() = default;
    MessageBuffer(const MessageBuffer&) = delete;
    MessageBuffer& operator=(const MessageBuffer&) = delete;
    ~MessageBuffer() { release(); }

    bool reserve(size_t capacity) {
        void* p = ::mmap(nullptr, std::max<size_t>(capacity, 1), PROT_READ | PROT_WRITE,
                         MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
        if (p == MAP_FAILED) return false;
        (void)::madvise(p, capacity, MADV_HUGEPAGE);  // a hint; without THP, plain pages
        mData = static_cast<uint8_t*>(p);
        mCapacity = std::max<size_t>(capacity, 1);
        return true;
    }
    void release() {
        if (mData) ::munmap(mData, mCapacity);
        mData = nullptr;
        mCapacity = mSize = 0;
    }
    uint8_t* end() { return mData + mSize; }
    size_t room() const { return mCapacity - mSize; }
    void grow(size_t n) { mSize += n; }
    std::span<const uint8_t> bytes() const { return {mData, mSize}; }

private:
    uint8_t* mData = nullptr;
    size_t mCapacity = 0, mSize = 0;
};

// Reads up to n bytes into p once fd is readable: the count, 0 at EOF, or nothing on an error
// or the deadline (*end says which).
std::optional<size_t> readSome(int fd, Clock::time_point deadline, void* p, size_t n,
                               ReadEnd* end) {
    for (;;) {
        if (auto failed = waitReadable(fd, deadline)) return (*end = *failed), std::nullopt;
        ssize_t k = ::read(fd, p, n);
        if (k >= 0) return size_t(k);
        if (errno != EINTR && errno != EAGAIN) return (*end = ReadEnd::kError), std::nullopt;
    }
}

// Reads the child's message (u64 length, then the wire bytes) until EOF, the deadline, or a
// length over the memory limit. At EOF, out holds the wire bytes that arrived (all of them when
// the child finished; fewer make decode fail).
ReadEnd readResult(int fd, Clock::time_point deadline, size_t maxBytes, MessageBuffer* out) {
    uint64_t length = 0;
    size_t got = 0;
    ReadEnd end = ReadEnd::kEof;
    while (got < sizeof length) {
        auto n = readSome(fd, deadline, reinterpret_cast<uint8_t*>(&length) + got,
                          sizeof length - got, &end);
        if (!n) return end;
        if (*n == 0) return ReadEnd::kEof;  // no message: decode reports the missing header
        got += *n;
    }
    if (length > maxBytes) return ReadEnd::kTooLarge;
    if (!out->reserve(size_t(length))) return ReadEnd::kTooLarge;
    while (out->room() > 0) {
        auto n = readSome(fd, deadline, out->end(), out->room(), &end);
        if (!n) return end;
        if (*n == 0) return ReadEnd::kEof;
        out->grow(*n);
    }
    return awaitEof(fd, deadline);
}

std::string signalText(int sig) {
    switch (sig) {
        case SIGSEGV:
            return "crashed (segmentation fault)";
        case SIGABRT:
            return "crashed (aborted by a failed check inside the parser)";
        case SIGBUS:
            return "crashed (bus error)";
        case SIGFPE:
            return "crashed (arithmetic exception)";
        case SIGILL:
            return "crashed (illegal instruction)";
        case SIGKILL:
            return "was killed (SIGKILL: the system may have run out of memory)";
        default:
            return fmt::format("was killed by signal {}", sig);
    }
}

// The one-line error for a child that ended without a usable result.
Status childFailure(const std::string& path, const IsolationLimits& limits, ReadEnd end,
                    int waitStatus, const Status& decodeError) {
    auto fail = [&](ErrorCode code, const std::string& what) {
        return errorStatus(code, fmt::format("{}: {} while importing (isolated)", path, what));
    };
    const size_t mb = limits.maxMemoryBytes >> 20;
    if (end == ReadEnd::kDeadline || (WIFSIGNALED(waitStatus) && WTERMSIG(waitStatus) == SIGXCPU))
        return fail(ErrorCode::kOutOfRange,
                    fmt::format("took longer than {:g} s (the time limit)", limits.maxSeconds));
    if (end == ReadEnd::kTooLarge)
        return fail(ErrorCode::kOutOfRange,
                    fmt::format("made a scene larger than {} MB (the memory limit)", mb));
    if (WIFSIGNALED(waitStatus))
        return fail(ErrorCode::kCorruptData, signalText(WTERMSIG(waitStatus)));
    if (!decodeError.isOk()) return fail(ErrorCode::kInternal, decodeError.message());
    return fail(ErrorCode::kInternal,
                fmt::format("the import process exited with status {} and no result",
                            WIFEXITED(waitStatus) ? WEXITSTATUS(waitStatus) : -1));
}

int waitChild(pid_t pid) {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    return status;
}

}  // namespace

Result<Scene> importFileIsolated(const std::string& path, const ImportOptions& options) {
    const IsolationLimits& limits = options.isolation;
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0)
        return errorStatus(ErrorCode::kIoError, path + ": cannot create a pipe for the import");
    (void)::fcntl(fds[0], F_SETPIPE_SZ, 1 << 20);  // fewer wake-ups for large scenes
    const rlim_t addressSpace = addressSpaceFor(limits);
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(limits.maxSeconds));
    pid_t pid = ::fork();
    if (pid == 0) {
        ::close(fds[0]);
        runChild(fds[1], path, options, addressSpace);
    }
    ::close(fds[1]);
    if (pid < 0) {
        ::close(fds[0]);
        return errorStatus(ErrorCode::kIoError, path + ": cannot start the import process");
    }
    MessageBuffer bytes;
    ReadEnd end = readResult(fds[0], deadline, limits.maxMemoryBytes, &bytes);
    ::close(fds[0]);
    if (end != ReadEnd::kEof) ::kill(pid, SIGKILL);
    // Decoded before waiting, overlapping the child's teardown; used only if it exits cleanly.
    Result<wire::Decoded> decoded = errorStatus(ErrorCode::kInternal, "no result");
    if (end == ReadEnd::kEof) decoded = wire::decode(bytes.bytes());
    bytes.release();
    int status = waitChild(pid);
    Status decodeError;
    if (end == ReadEnd::kEof && WIFEXITED(status) && WEXITSTATUS(status) == 0) {
        if (decoded && decoded->outcome == wire::WireOutcome::kScene) {
            // The one finalize of the scene, as an in-process import ends (and with its errors).
            Status finalized = decoded->scene.finalize();
            if (!finalized) return errorStatus(finalized.code(), path + ": " + finalized.message());
            return std::move(decoded->scene);
        }
        if (decoded && decoded->outcome == wire::WireOutcome::kOutOfMemory)
            return errorStatus(ErrorCode::kOutOfRange,
                               fmt::format("{}: needed more than {} MB of memory (the limit) "
                                           "while importing (isolated)",
                                           path, limits.maxMemoryBytes >> 20));
        if (decoded) return decoded->status;
        decodeError = decoded.status();
    }
    return childFailure(path, limits, end, status, decodeError);
}

}  // namespace plx::scene
