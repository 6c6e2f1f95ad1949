// parallax serve SCENE: the render server of Mark, Bishop, McMillan's remote rendering system
// (libs/remote, server.h). Streams reference sets over WebSocket to `parallax client` until
// Ctrl-C or SIGTERM (or --seconds), then says Bye(GoingAway) to every session.

#include <poll.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <mutex>

#include <fmt/format.h>

#include <plx/remote/server.h>

#include "commands.h"
#include "experiment_warp.h"
#include "view.h"
#include "web_assets.h"

namespace plx::cli {
namespace {

struct ServeArgs {
    std::string scene;
    int port = 8080;
    std::string bind = "127.0.0.1";
    std::string token;
    std::string refs = "cube4";
    int faceSize = 512;
    int maxSessions = 16;
    int maxSessionsPerAddress = 0;
    int maxPending = 64;
    double writeTimeoutS = 30.0;
    double idleTimeoutS = 30.0;
    double maxQueuedMiB = 256.0;
    double latencyMs = 0.0, jitterMs = 0.0, bandwidthMbit = 0.0;
    std::string prediction = "velocity";
    int threads = 0;
    double seconds = 0.0;
    bool json = false;
};

Result<remote::ServerConfig> plan(const ServeArgs& a) {
    remote::ServerConfig c;
    c.bind = a.bind;
    c.port = a.port;
    c.token = a.token;
    auto layout = warp::parseReferenceLayout(a.refs);
    if (!layout) return layout.status();
    c.reference.layout = *layout;
    c.reference.faceSize = a.faceSize;
    c.maxSessions = a.maxSessions;
    c.maxSessionsPerAddress = a.maxSessionsPerAddress;
    c.maxPendingConnections = a.maxPending;
    c.writeStallTimeoutMs = a.writeTimeoutS * 1000.0;
    c.idleTimeoutMs = a.idleTimeoutS * 1000.0;
    c.link.latencyMs = a.latencyMs;
    c.link.jitterMs = a.jitterMs;
    c.link.bandwidthMbit = a.bandwidthMbit;
    auto prediction = remote::parsePrediction(a.prediction);
    if (!prediction) return prediction.status();
    c.prediction = *prediction;
    c.renderThreads = a.threads;
    // The browser client, from the assets compiled into the binary (never the file system).
    c.pages = [](std::string_view path) -> std::optional<remote::HttpFile> {
        std::optional<WebAsset> asset = webAsset(path);
        if (!asset) return std::nullopt;
        return remote::HttpFile{asset->bytes,
                                std::string(asset->contentType),
                                {{"Content-Security-Policy", std::string(kPageSecurityPolicy)},
                                 {"Referrer-Policy", "no-referrer"}}};
    };
    if (!(a.seconds >= 0.0 && a.seconds <= 1e6))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--seconds {} outside 0 .. 1e6", a.seconds));
    if (!(a.maxQueuedMiB >= 1.0 && a.maxQueuedMiB <= 1048576.0))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--max-queued {} MiB outside 1 .. 1048576", a.maxQueuedMiB));
    c.maxQueuedSetBytes = size_t(mebibytes(a.maxQueuedMiB));
    PLX_RETURN_IF_ERROR(remote::checkServerConfig(c));
    return c;
}

// Blocks SIGINT and SIGTERM in this thread and every thread started after it, so that only
// waitForStop receives them.
sigset_t blockStopSignals() {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    return set;
}

// Until a stop signal, or `seconds` have passed (0: no limit).
void waitForStop(const sigset_t& set, double seconds) {
    if (seconds <= 0.0) {
        int sig = 0;
        sigwait(&set, &sig);
        return;
    }
    timespec limit{time_t(seconds), long((seconds - double(time_t(seconds))) * 1e9)};
    sigtimedwait(&set, nullptr, &limit);
}

// Peak bytes per pixel of the largest reference set a session can ask for, beyond the scene
// (checkImageMemory): the one render worker's targets and set, and the set's encoding. The growth
// of the peak with one client from faces of 1024 to 2048 (office:1) is 8.3 (cube4) and 8.2
// (cube6); rounded up, RemoteCli.ServeMemoryEstimateHoldsItsPeak holds it to the peak.
constexpr double kServeBytesPerSetPixel = 9.0;
// An encoded set's bytes per pixel at most: its raw colour and disparity (on office:2 at 2048 it
// is 1/133 of that).
constexpr double kEncodedSetBytesPerPixel = 8.0;

// Refuses a server whose sets and queue would not fit: the queue at its bound (each session's
// one encoded set, or --max-queued plus one set if less). Returns the peak with one client, whose
// queue holds one set of a small fraction of the raw bytes, for --json.
Result<uint64_t> checkServeMemory(const ServeArgs& a, const remote::ServerConfig& config,
                                  size_t triangles) {
    warp::ReferenceSetOptions largest = config.reference;
    largest.faceSize = remote::maxServedFaceSize(largest);
    auto pixels = referencePixels(largest);
    if (!pixels) return pixels.status();
    const double setBytes = kEncodedSetBytesPerPixel * double(*pixels);
    const double queueBytes = std::min(double(config.maxSessions) * setBytes,
                                       double(config.maxQueuedSetBytes) + setBytes);
    auto withQueue = checkImageMemory(
        fmt::format("serve --refs {} --face-size {} --max-sessions {} --max-queued {}", a.refs,
                    a.faceSize, a.maxSessions, a.maxQueuedMiB),
        kServeBytesPerSetPixel * double(*pixels) + queueBytes, triangles);
    if (!withQueue) return withQueue.status();
    return *withQueue - uint64_t(queueBytes);
}

// serve's stdout: the listening line, the session log (a line per remote::SessionEvent: text, or
// with --json a JSON line, "session_accepted", "session_refused", "session_ended") and the stopped
// line. Whole lines under `mutex`, which runServe holds until the listening line is out, so that
// the session lines from the transport's thread come after it.
//
// A reader that is gone or stops reading must not stop the server: SIGPIPE is ignored (runServe)
// and write errors with it (`serve --json | head -1`), and a line waits at most `waitMs` for room
// in a full pipe, then is dropped and counted. Session lines wait not at all: they are written
// on the transport's I/O thread, which a blocked write would stop for every session (a script
// that reads only the listening line, then nothing until it stops the server).
struct ServeOutput {
    bool json = false;
    std::mutex mutex;
    int64_t dropped = 0;  // lines, or their ends, not written

    // The caller holds `mutex`. Raw writes of at most PIPE_BUF bytes, each after poll said there
    // is room: such a write to a pipe goes in whole without blocking.
    void writeLocked(const std::string& text, int waitMs) {
        const std::string line = text + "\n";
        for (size_t at = 0; at < line.size();) {
            pollfd out{STDOUT_FILENO, POLLOUT, 0};
            const ssize_t n = poll(&out, 1, waitMs) == 1 && (out.revents & POLLOUT)
                                  ? write(STDOUT_FILENO, line.data() + at,
                                          std::min<size_t>(line.size() - at, PIPE_BUF))
                                  : -1;
            if (n <= 0) {
                ++dropped;
                return;
            }
            at += size_t(n);
        }
    }

    void session(const remote::SessionEvent& e) {
        using Kind = remote::SessionEvent::Kind;
        std::string line;
        if (json) {
            nlohmann::json j{{"event", fmt::format("session_{}", remote::sessionEventName(e.kind))},
                             {"session", e.session},
                             {"address", e.address}};
            if (e.kind == Kind::kAccepted) j["face_size"] = e.faceSize;
            if (e.kind != Kind::kAccepted) j["reason"] = e.reason;
            if (e.kind == Kind::kEnded)
                j.update({{"duration_s", e.durationS},
                          {"sets_sent", e.setsSent},
                          {"bytes_sent", e.bytesSent}});
            line = jsonText(j);
        } else {
            line = fmt::format("session {} from {}: {}", e.session, e.address,
                               remote::sessionEventName(e.kind));
            if (e.kind == Kind::kAccepted) line += fmt::format(" ({} px faces)", e.faceSize);
            if (e.kind == Kind::kEnded)
                line +=
                    fmt::format(" after {:.1f} s, {} ({:.1f} KiB)", e.durationS,
                                counted(uint64_t(e.setsSent), "set"), double(e.bytesSent) / 1024.0);
            if (e.kind != Kind::kAccepted) line += ": " + e.reason;
        }
        std::lock_guard lock(mutex);
        writeLocked(line, 0);
    }
};

// How long serve's listening and stopped lines wait for a reader to make room (ServeOutput).
constexpr int kServeLineWaitMs = 1000;

// File descriptors a server holds beyond its connections' sockets: 9 at start (standard streams,
// the I/O thread's epoll, eventfd and timerfd), with room to spare.
constexpr uint64_t kServeBaseFiles = 32;

// Each session and each pending connection (not yet a session, or closing) holds a socket. Raises
// the soft limit on open files to what they need, as far as the hard limit allows (a soft limit of
// 1024 is common), and warns when even that falls short: accepts past it fail and are retried 5 ms
// to 1 s apart until connections close. Returns the limit now.
Result<uint64_t> raiseOpenFilesLimit(const ServeArgs& a) {
    const uint64_t needed = uint64_t(a.maxSessions) + uint64_t(a.maxPending) + kServeBaseFiles;
    rlimit limit{};
    if (getrlimit(RLIMIT_NOFILE, &limit) != 0) return uint64_t(0);
    if (limit.rlim_cur < needed) {
        rlimit raised = limit;
        raised.rlim_cur = std::min<rlim_t>(needed, limit.rlim_max);
        if (setrlimit(RLIMIT_NOFILE, &raised) == 0) limit = raised;
    }
    if (limit.rlim_cur < needed)
        PLX_RETURN_IF_ERROR(warn(fmt::format(
            "{} open files allowed (ulimit -n); --max-sessions {} and --max-pending {} need about "
            "{}: connections past it wait",
            limit.rlim_cur, a.maxSessions, a.maxPending, needed)));
    return uint64_t(limit.rlim_cur);
}

int runServe(const ServeArgs& a) {
    auto config = plan(a);
    if (!config) return fail(config.status().message(), kExitUsage);
    auto scene = loadSceneChecked(a.scene);
    if (!scene) return fail(scene.status());
    auto memory = checkServeMemory(a, *config, scene->triangleCount());
    if (!memory) return fail(memory.status());
    auto openFiles = raiseOpenFilesLimit(a);
    if (!openFiles) return fail(openFiles.status());
    const size_t triangles = scene->triangleCount();
    const sigset_t stopSignals = blockStopSignals();
    std::signal(SIGPIPE, SIG_IGN);
    ServeOutput out;
    out.json = a.json;
    config->onSessionEvent = [&out](const remote::SessionEvent& e) { out.session(e); };
    std::unique_lock holdOutput(out.mutex);  // until the listening line is out
    auto server = remote::Server::create(std::move(scene).value(), *config);
    if (!server) return fail(server.status());
    const std::string url = fmt::format("ws://{}/", remote::authority(a.bind, (*server)->port()));
    // The largest a session gets: --face-size, lowered for wide views no client could decode.
    const int servedFaceSize = remote::maxServedFaceSize(config->reference);
    if (a.json) {
        out.writeLocked(jsonText(nlohmann::json{{"event", "listening"},
                                                {"url", url},
                                                {"bind", a.bind},
                                                {"port", (*server)->port()},
                                                {"scene", a.scene},
                                                {"triangles", triangles},
                                                {"refs", a.refs},
                                                {"face_size", servedFaceSize},
                                                {"open_files", *openFiles},
                                                {"prediction", a.prediction}}),
                        kServeLineWaitMs);
    } else {
        out.writeLocked(
            fmt::format(
                "serving {} ({} triangles) on {} ({} faces of {} px, prediction {}); Ctrl-C stops",
                a.scene, triangles, url, a.refs, servedFaceSize, a.prediction),
            kServeLineWaitMs);
    }
    holdOutput.unlock();
    waitForStop(stopSignals, a.seconds);
    (*server)->stop();  // the last session lines are out when it returns
    remote::ServerStats s = (*server)->stats();
    holdOutput.lock();
    if (a.json) {
        nlohmann::json stopped{{"event", "stopped"},
                               {"sessions_total", s.sessionsTotal},
                               {"refused", s.refused},
                               {"protocol_errors", s.protocolErrors},
                               {"write_stalls", s.writeStalls},
                               {"idle_timeouts", s.idleTimeouts},
                               {"queue_waits", s.queueWaits},
                               {"pending_dropped", s.pendingDropped},
                               {"accept_failures", s.acceptFailures},
                               {"sets_sent", s.setsSent},
                               {"bytes_sent", s.bytesSent},
                               {"raw_bytes_sent", s.rawBytesSent},
                               {"max_queued_bytes", s.maxQueuedBytes},
                               {"max_set_bytes", s.maxSetBytes},
                               {"render_ms_mean", valueOrNull(s.setsSent > 0, s.renderMsMean)},
                               {"encode_ms_mean", valueOrNull(s.setsSent > 0, s.encodeMsMean)},
                               {"lines_dropped", out.dropped}};
        stopped.update(memoryJson(*memory));
        out.writeLocked(jsonText(stopped), kServeLineWaitMs);
    } else {
        // Per-set figures only where a set was sent ("1/0 of raw" said nothing).
        const std::string perSet =
            s.setsSent == 0
                ? std::string()
                : fmt::format(
                      " ({:.1f} KiB each, 1/{:.0f} of raw), render {:.1f} ms + encode "
                      "{:.1f} ms per set",
                      double(s.bytesSent) / double(s.setsSent) / 1024.0,
                      double(s.rawBytesSent) / double(s.bytesSent), s.renderMsMean, s.encodeMsMean);
        out.writeLocked(
            fmt::format("stopped: {}, {} sent{}{}", counted(uint64_t(s.sessionsTotal), "session"),
                        counted(uint64_t(s.setsSent), "set"), perSet,
                        out.dropped ? fmt::format("; {} output lines dropped", out.dropped) : ""),
            kServeLineWaitMs);
    }
    return kExitOk;
}

}  // namespace

Command registerServe(CLI::App& app) {
    auto a = std::make_shared<ServeArgs>();
    CLI::App* sub = app.add_subcommand(
        "serve", "Serve reference sets of a scene to remote warping clients (WebSocket)");
    sub->footer(
        "Example: parallax serve office:8 --port 8080 --face-size 512 --token secret\n"
        "         parallax client ws://127.0.0.1:8080 --token secret --walk 300 --scene office:8\n"
        "Listens on 127.0.0.1 unless --bind says otherwise; --port 0 picks a free port. With "
        "--json, stdout has one JSON line when listening ({\"event\":\"listening\",\"port\":...}), "
        "one per client accepted, refused or ended (session_accepted, session_refused, "
        "session_ended: session number, address, reason, sets sent) and one when stopped "
        "(totals); without it, the same as text. The wire protocol: docs/remote-protocol.md.");
    sub->add_option("scene", a->scene, "Model file or generator spec (office:N, museum:N)")
        ->required();
    sub->add_option("--port", a->port, "TCP port (0: a free one, printed)")->capture_default_str();
    sub->add_option("--bind", a->bind, "Address to listen on")->capture_default_str();
    sub->add_option("--token", a->token, "Clients must present this token");
    sub->add_option("--refs", a->refs, "cube4 | cube6 | wide: the reference views")
        ->capture_default_str();
    sub->add_option("--face-size", a->faceSize,
                    "Largest face side rendered (a client asking less gets less)")
        ->capture_default_str();
    sub->add_option("--max-sessions", a->maxSessions, "Sessions at once; more are refused")
        ->capture_default_str();
    sub->add_option("--max-sessions-per-address", a->maxSessionsPerAddress,
                    "Sessions at once from one client address (IPv6: one /64); more are refused "
                    "(0: no limit; behind a proxy every client has its address)")
        ->capture_default_str();
    sub->add_option("--max-pending", a->maxPending,
                    "Connections without a session (not said hello yet, or closing); one more "
                    "drops the oldest of the client address with the most")
        ->capture_default_str();
    sub->add_option("--write-timeout", a->writeTimeoutS,
                    "Drop a session whose socket takes no 64 KiB in this many seconds (its peer "
                    "stopped reading)")
        ->capture_default_str();
    sub->add_option("--idle-timeout", a->idleTimeoutS,
                    "End a session whose client sends nothing (no pose, ping or pong) in this "
                    "many seconds")
        ->capture_default_str()
        ->check(floatNumber());
    sub->add_option("--max-queued", a->maxQueuedMiB,
                    "MiB of encoded sets all sessions may queue on their sockets; past it, "
                    "renders wait")
        ->capture_default_str();
    sub->add_option("--latency", a->latencyMs, "Emulated one-way latency, ms (both directions)");
    sub->add_option("--jitter", a->jitterMs, "Emulated extra delay, uniform in 0..MS per message");
    sub->add_option("--bandwidth", a->bandwidthMbit, "Emulated link rate, Mbit/s (0: unlimited)");
    sub->add_option("--prediction", a->prediction,
                    "velocity (render ahead along the pose's velocity) | none")
        ->capture_default_str();
    sub->add_option("--threads", a->threads, "Render threads (0: all cores)");
    sub->add_option("--seconds", a->seconds, "Stop after this long (0: at Ctrl-C or SIGTERM)");
    sub->add_flag("--json", a->json, "JSON lines on stdout (listening, sessions, stopped)");
    return {sub, [a] { return runServe(*a); }};
}

}  // namespace plx::cli
