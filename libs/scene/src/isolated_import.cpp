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
#include <vector>

#include <fcntl.h>
#include <malloc.h>
#include <poll.h>
#include <pthread.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

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

// Gathers small fields into one buffer; large arrays go to the pipe directly, without a copy.
class PipeSink {
public:
    explicit PipeSink(int fd) : mFd(fd) { mBuffer.reserve(kBufferBytes); }
    bool put(const void* p, size_t n) {
        if (mBuffer.size() + n > kBufferBytes && !flush()) return false;
        if (n >= kBufferBytes) return writeAll(mFd, p, n);
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
        Result<Scene> scene = importFile(*job->path, job->options);
        if (scene) {
            job->written =
                sendFramed(pipe, [&](const wire::Sink& s) { return wire::encodeScene(*scene, s); });
            // EOF now: the parent decodes while this process frees the scene and exits.
            ::close(kChildFd);
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
    FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return 0;
    unsigned long pages = 0;
    bool ok = std::fscanf(f, "%lu", &pages) == 1;
    std::fclose(f);
    if (!ok) return 0;
    return rlim_t(pages) * rlim_t(::sysconf(_SC_PAGESIZE)) + limits.maxMemoryBytes +
           limits.maxStackBytes;
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

// Reads the child's message (u64 length, then the wire bytes) until EOF, the deadline, or a
// length over the memory limit. The buffer grows as bytes arrive (at once to the whole message
// up to 64 MiB, then doubling), so that a length alone commits no memory.
ReadEnd readResult(int fd, Clock::time_point deadline, size_t maxBytes, std::vector<uint8_t>* out) {
    constexpr size_t kFirstChunk = size_t(64) << 20;
    uint64_t length = 0;
    bool haveLength = false;
    size_t size = 0;
    out->resize(sizeof length);
    for (;;) {
        if (auto failed = waitReadable(fd, deadline)) return *failed;
        ssize_t n = ::read(fd, out->data() + size, out->size() - size);
        if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
        if (n < 0) return ReadEnd::kError;
        if (n == 0) break;
        size += size_t(n);
        if (!haveLength && size == sizeof length) {
            std::memcpy(&length, out->data(), sizeof length);
            if (length > maxBytes) return ReadEnd::kTooLarge;
            haveLength = true;
        }
        const size_t whole = sizeof length + size_t(length);
        if (haveLength && size == whole) return awaitEof(fd, deadline);
        if (size == out->size()) out->resize(std::min(whole, std::max(2 * size, kFirstChunk)));
    }
    out->resize(size);
    return ReadEnd::kEof;
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
    std::vector<uint8_t> bytes;
    ReadEnd end = readResult(fds[0], deadline, limits.maxMemoryBytes, &bytes);
    ::close(fds[0]);
    if (end != ReadEnd::kEof) ::kill(pid, SIGKILL);
    // Decoded before waiting, overlapping the child's teardown; used only if it exits cleanly.
    Result<wire::Decoded> decoded = errorStatus(ErrorCode::kInternal, "no result");
    if (end == ReadEnd::kEof)  // the wire message follows its u64 length
        decoded = wire::decode(
            std::span<const uint8_t>(bytes).subspan(std::min(bytes.size(), sizeof(uint64_t))));
    bytes = {};
    int status = waitChild(pid);
    Status decodeError;
    if (end == ReadEnd::kEof && WIFEXITED(status) && WEXITSTATUS(status) == 0) {
        if (decoded && decoded->outcome == wire::WireOutcome::kScene)
            return std::move(decoded->scene);
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
