// The render server: sessions over the transport, a one-slot pose mailbox per session, one
// render worker serving sessions in turn (docs/remote-protocol.md, "Session").

#include <plx/remote/server.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include <fmt/format.h>

#include <plx/core/parallel.h>
#include <plx/raster/raster.h>
#include <plx/remote/codec.h>
#include <plx/remote/protocol.h>
#include <plx/warp/reference.h>

#include "one_unwritten.h"

namespace plx::remote {

using Clock = std::chrono::steady_clock;

Result<Prediction> parsePrediction(const std::string& name) {
    if (name == "none") return Prediction::kNone;
    if (name == "velocity") return Prediction::kConstantVelocity;
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("unknown prediction '{}' (none, velocity)", name));
}

const char* predictionName(Prediction prediction) {
    return prediction == Prediction::kNone ? "none" : "velocity";
}

const char* sessionEventName(SessionEvent::Kind kind) {
    switch (kind) {
        case SessionEvent::Kind::kAccepted:
            return "accepted";
        case SessionEvent::Kind::kRefused:
            return "refused";
        case SessionEvent::Kind::kEnded:
            return "ended";
    }
    return "?";
}

Vec3 predictEye(const Vec3& eye, const Vec3& velocity, double leadMs) {
    const double lead = std::clamp(leadMs, 0.0, 1000.0) * 1e-3;
    return eye + velocity * float(lead);
}

int maxServedFaceSize(const warp::ReferenceSetOptions& r) {
    if (r.layout != warp::ReferenceLayout::kWide || !(r.wideAspect > 0.0f)) return r.faceSize;
    // The width referenceCameras gives, lround(face x aspect), at most maxViewSide: the face
    // below (maxViewSide + 0.5) / aspect, then stepped down past any rounding of that quotient.
    const int maxSide = DecodeLimits{}.maxViewSide;
    const double aspect = double(r.wideAspect);
    int face = int(std::min(double(r.faceSize), std::ceil((double(maxSide) + 0.5) / aspect) - 1.0));
    while (face > 1 && std::lround(double(face) * aspect) > maxSide) --face;
    return face;
}

Status checkServerConfig(const ServerConfig& c) {
    auto bad = [](const std::string& m) { return errorStatus(ErrorCode::kInvalidArgument, m); };
    if (c.port < 0 || c.port > 65535) return bad(fmt::format("port {} outside 0..65535", c.port));
    if (!enumWithin(c.prediction, Prediction::kNone, Prediction::kConstantVelocity))
        return bad("unknown prediction");
    PLX_RETURN_IF_ERROR(checkBindAddress(c.bind));
    if (c.token.size() > size_t(kMaxTokenBytes))
        return bad(fmt::format("token longer than {} bytes", kMaxTokenBytes));
    if (c.reference.faceSize < kMinFaceSize || c.reference.faceSize > kMaxFaceSize)
        return bad(fmt::format("face size {} outside {}..{}", c.reference.faceSize, kMinFaceSize,
                               kMaxFaceSize));
    if (c.maxSessions < 1 || c.maxSessions > 1024)
        return bad(fmt::format("max sessions {} outside 1..1024", c.maxSessions));
    if (c.maxSessionsPerAddress < 0 || c.maxSessionsPerAddress > 1024)
        return bad(
            fmt::format("max sessions per address {} outside 0..1024", c.maxSessionsPerAddress));
    if (c.poseRateHz < 1 || c.poseRateHz > 1000)
        return bad(fmt::format("pose rate {} outside 1..1000", c.poseRateHz));
    if (!(c.pingIntervalMs >= 10.0 && c.pingIntervalMs <= 60000.0))
        return bad(fmt::format("ping interval {} ms outside 10..60000", c.pingIntervalMs));
    PLX_RETURN_IF_ERROR(checkThreadCount(c.renderThreads, "render threads"));
    PLX_RETURN_IF_ERROR(checkLinkEmulation(c.link));
    PLX_RETURN_IF_ERROR(checkWriteStallTimeout(c.writeStallTimeoutMs));
    if (!(c.idleTimeoutMs >= 1000.0 && c.idleTimeoutMs <= 3600e3))
        return bad(fmt::format("idle timeout {} s outside 1..3600", c.idleTimeoutMs / 1000.0));
    if (!(c.idleTimeoutMs > 2.0 * c.pingIntervalMs))
        return bad(fmt::format("idle timeout {} s must exceed two ping intervals ({} ms)",
                               c.idleTimeoutMs / 1000.0, c.pingIntervalMs));
    PLX_RETURN_IF_ERROR(checkMaxPending(c.maxPendingConnections));
    if (c.maxQueuedSetBytes < 1) return bad("max queued set bytes must be at least 1");
    // The sets it renders: at most maxServedFaceSize, whatever a session asks for.
    warp::ReferenceSetOptions served = c.reference;
    served.faceSize = maxServedFaceSize(c.reference);
    if (served.faceSize < kMinFaceSize)
        return bad(fmt::format("wide aspect {} leaves views under {} pixels high within {} wide",
                               c.reference.wideAspect, kMinFaceSize, DecodeLimits{}.maxViewSide));
    return warp::checkReferenceSetOptions(served);
}

namespace {

// A client that has not said hello after this long is dropped (it holds a connection slot).
constexpr double kHelloTimeoutMs = 5000.0;
// A session that has sent no pose this long after connecting gets a first set at the scene's
// default viewpoint (requestTimestampUs 0), so that a client with no pose of its own (the
// browser page) has something to show and walk from. Clients that send a pose at once (the
// native client) never see it.
constexpr double kInitialSetAfterMs = 300.0;
// Ping answers per second per session (docs/remote-protocol.md); extra pings are not answered.
constexpr int kMaxPingsPerSecond = 10;
// The server's largest message from a client: Error and Bye at 2 KiB (docs/remote-protocol.md).
constexpr size_t kMaxClientMessageBytes = 2048;

uint64_t nowUs() {
    return uint64_t(
        std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch())
            .count());
}

double msSince(Clock::time_point t) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

enum class SessionState { kAwaitingHello, kAccepted, kClosed };

struct Session {
    std::shared_ptr<Connection> conn;
    Clock::time_point connectedAt = Clock::now();
    Clock::time_point lastHeard = Clock::now();  // the client's latest message (idleTimeoutMs)
    uint64_t number = 0;  // SessionEvent::session
    // Guarded by Server::Impl::mutex.
    SessionState state = SessionState::kAwaitingHello;
    bool accepted = false;  // its hello was: its end is logged (SessionEvent::kEnded)
    std::string endReason;  // why the server ended it; empty when the connection ended it
    int64_t setsSent = 0, bytesSent = 0;
    int faceSize = 0;
    // The disparity codec of this client's sets: the server's unless the client cannot decode it
    // (ClientHello::disparityCodecs; a browser has no zstd).
    DisparityCodec disparityCodec = DisparityCodec::kQuantized16Packed;
    std::optional<PoseMessage> pending;   // the one-slot mailbox
    Clock::time_point pendingAt;          // when the pending pose arrived
    std::optional<PoseMessage> lastPose;  // for the velocity estimate without a velocity field
    Vec3 estimatedVelocity{0.0f};
    bool inFlight = false;       // a set is being rendered or waits on the socket
    bool ready = false;          // in the ready queue
    bool initialQueued = false;  // the default-viewpoint set was queued (kInitialSetAfterMs)
    uint32_t sequence = 0;
    double rttMs = -1.0;  // smoothed round trip, < 0 before the first Pong
    Clock::time_point lastPingSent{};
    uint32_t pingNonce = 0;
    Clock::time_point pingWindow{};
    int pingsInWindow = 0;
    OneUnwritten pings, pongs;  // a peer that stops reading gets no queue of them
};
using SessionPtr = std::shared_ptr<Session>;

// A viewpoint as a pose (forward toward the target, up made orthogonal to it); nullopt when the
// viewpoint is degenerate or the pose would break the protocol's checks.
std::optional<warp::Pose> poseAt(const scene::Viewpoint& v) {
    const Vec3 toTarget = v.targetPos - v.eyePos;
    if (!(glm::length(toTarget) > 1e-6f)) return std::nullopt;
    warp::Pose pose;
    pose.eye = v.eyePos;
    pose.forward = glm::normalize(toTarget);
    const Vec3 side = glm::cross(pose.forward, v.upDir);
    if (!(glm::length(side) > 1e-3f)) return std::nullopt;
    pose.up = glm::normalize(glm::cross(glm::normalize(side), pose.forward));
    if (!warp::checkPose(pose)) return std::nullopt;
    return pose;
}

}  // namespace

struct Server::Impl {
    std::shared_ptr<const scene::Scene> scene;  // never null
    ServerConfig config;
    std::unique_ptr<Transport> transport;
    std::unique_ptr<raster::Renderer> renderer;
    int port = 0;

    mutable std::mutex mutex;
    std::condition_variable wake;
    std::set<SessionPtr> sessions;
    std::deque<SessionPtr> ready;
    bool stopping = false, stopped = false;
    std::thread worker;
    ServerStats stats;
    size_t setBytesQueued = 0;              // encoded sets handed to sockets, not yet written
    bool waitingForQueue = false;           // renders wait for setBytesQueued to fall
    double renderEncodeMsEstimate = 0.0;    // smoothed, for the prediction lead
    std::optional<warp::Pose> initialPose;  // the scene's default viewpoint, when valid
    uint64_t connections = 0;               // accepted connections so far (Session::number)

    // An entry of the session log (ServerConfig::onSessionEvent), and its report, which is
    // made without the lock.
    static SessionEvent eventOf(SessionEvent::Kind kind, const Session& s, std::string reason) {
        SessionEvent e;
        e.kind = kind;
        e.session = s.number;
        e.address = s.conn->peerAddress();
        e.faceSize = s.faceSize;
        e.reason = std::move(reason);
        return e;
    }
    void report(const SessionEvent& e) const {
        if (config.onSessionEvent) config.onSessionEvent(e);
    }

    void send(const SessionPtr& s, const Message& m, std::function<void(const Status&)> done = {}) {
        auto bytes = encodeMessage(m, config.codec);
        if (!bytes) return;  // well-formed by construction; nothing to send otherwise
        s->conn->send(std::move(bytes).value(), std::move(done));
    }

    // Ends a session with an Error message (sent before the close). One that had not said
    // hello is logged as refused; an accepted one's end is logged when its connection ends.
    void fail(const SessionPtr& s, ErrorKind kind, std::string text) {
        if (text.size() > size_t(kMaxTextBytes)) text.resize(size_t(kMaxTextBytes));
        bool beforeHello = false;
        {
            std::lock_guard lock(mutex);
            if (s->state == SessionState::kClosed) return;
            if (kind == ErrorKind::kProtocol || kind == ErrorKind::kTooLarge)
                ++stats.protocolErrors;
            if (s->state == SessionState::kAccepted) --stats.sessionsActive;
            beforeHello = s->state == SessionState::kAwaitingHello;
            s->state = SessionState::kClosed;
            s->endReason = "error: " + text;
        }
        send(s, ErrorMessage{kind, text});
        s->conn->close();
        if (beforeHello) report(eventOf(SessionEvent::Kind::kRefused, *s, "error: " + text));
    }

    void refuse(const SessionPtr& s, std::string reason, const ClientHello& hello) {
        {
            std::lock_guard lock(mutex);
            ++stats.refused;
            s->state = SessionState::kClosed;
        }
        ServerHello h;
        h.accepted = false;
        h.layout = config.reference.layout;
        h.faceSize = std::clamp(hello.faceSize, kMinFaceSize, kMaxFaceSize);
        h.poseRateHz = config.poseRateHz;
        h.reason = reason;
        send(s, h);
        s->conn->close();
        report(eventOf(SessionEvent::Kind::kRefused, *s, std::move(reason)));
    }

    void onHello(const SessionPtr& s, const ClientHello& hello) {
        if (hello.version != kProtocolVersion)
            return refuse(s,
                          fmt::format("unsupported protocol version {} (server speaks {})",
                                      hello.version, kProtocolVersion),
                          hello);
        if (!config.token.empty() && !tokensEqual(hello.token, config.token))
            return refuse(s, hello.token.empty() ? "a token is required" : "wrong token", hello);
        const DisparityCodec disparity = disparityCodecFor(hello.disparityCodecs);
        std::string full;
        {
            std::lock_guard lock(mutex);
            full = whyFullLocked(*s);
            if (full.empty()) {
                ++stats.sessionsActive;
                ++stats.sessionsTotal;
                s->state = SessionState::kAccepted;
                s->accepted = true;
                s->faceSize = std::min(hello.faceSize, maxServedFaceSize(config.reference));
                s->disparityCodec = disparity;
                ServerHello h;
                h.layout = config.reference.layout;
                h.faceSize = s->faceSize;
                h.poseRateHz = config.poseRateHz;
                // Queued before the lock is released: the worker pings accepted sessions
                // (housekeepLocked), and no Ping may reach the client before its ServerHello.
                send(s, h);
            } else {
                ++stats.refused;
                s->state = SessionState::kClosed;
            }
        }
        if (full.empty()) return report(eventOf(SessionEvent::Kind::kAccepted, *s, {}));
        send(s, ErrorMessage{ErrorKind::kOverloaded, full});
        s->conn->close();
        report(eventOf(SessionEvent::Kind::kRefused, *s, std::move(full)));
    }

    // Why `s` cannot be accepted now (maxSessions, maxSessionsPerAddress); empty when it can.
    std::string whyFullLocked(const Session& s) const {
        if (stats.sessionsActive >= config.maxSessions)
            return fmt::format("server full ({} sessions)", config.maxSessions);
        if (config.maxSessionsPerAddress == 0) return {};
        const std::string group = s.conn->peerGroup();
        const auto fromGroup =
            std::count_if(sessions.begin(), sessions.end(), [&](const SessionPtr& other) {
                return other->state == SessionState::kAccepted && other->conn->peerGroup() == group;
            });
        if (fromGroup < config.maxSessionsPerAddress) return {};
        return fmt::format("too many sessions from {} ({} at most)", group,
                           config.maxSessionsPerAddress);
    }

    // The server's configured disparity codec when the client decodes it, else the client's
    // preferred one (chooseDisparityCodec: q16-packed, q16, q16-deflate, raw).
    DisparityCodec disparityCodecFor(uint8_t clientCodecs) const {
        if (clientCodecs & disparityCodecBit(config.codec.disparity)) return config.codec.disparity;
        Result<DisparityCodec> chosen = chooseDisparityCodec(clientCodecs);
        return chosen ? *chosen : config.codec.disparity;  // the decoder refused an empty mask
    }

    // Equal tokens, compared in time independent of where they differ.
    static bool tokensEqual(const std::string& a, const std::string& b) {
        if (a.size() != b.size()) return false;
        unsigned diff = 0;
        for (size_t i = 0; i < a.size(); ++i) diff |= unsigned(uint8_t(a[i]) ^ uint8_t(b[i]));
        return diff == 0;
    }

    void onPose(const SessionPtr& s, const PoseMessage& pose) {
        std::lock_guard lock(mutex);
        // Velocity from successive poses when the client sends none (client clock deltas).
        if (s->lastPose && pose.timestampUs > s->lastPose->timestampUs) {
            double dt = double(pose.timestampUs - s->lastPose->timestampUs) * 1e-6;
            // Two poses a microsecond apart would otherwise imply any speed at all.
            if (dt <= 1.0)
                s->estimatedVelocity =
                    glm::clamp((pose.pose.eye - s->lastPose->pose.eye) / float(dt),
                               Vec3(-kMaxSpeedMps), Vec3(kMaxSpeedMps));
        }
        s->lastPose = pose;
        s->pending = pose;  // replaces an unserved one
        s->pendingAt = Clock::now();
        scheduleLocked(s);
    }

    void scheduleLocked(const SessionPtr& s) {
        if (s->state != SessionState::kAccepted || s->inFlight || s->ready || !s->pending) return;
        s->ready = true;
        ready.push_back(s);
        wake.notify_one();
    }

    void onPing(const SessionPtr& s, const Ping& ping) {
        {
            std::lock_guard lock(mutex);
            Clock::time_point now = Clock::now();
            if (now - s->pingWindow > std::chrono::seconds(1))
                s->pingWindow = now, s->pingsInWindow = 0;
            if (++s->pingsInWindow > kMaxPingsPerSecond) return;
        }
        s->pongs.send(*s->conn, Pong{ping.timestampUs, ping.nonce});
    }

    void onPong(const SessionPtr& s, const Pong& pong) {
        std::lock_guard lock(mutex);
        // One of our recent pings (a round trip may exceed the ping interval), not a forged one.
        if (s->pingNonce - pong.nonce >= 64u) return;
        double rtt = double(nowUs() - std::min(pong.timestampUs, nowUs())) * 1e-3;
        // Smoothed like TCP's SRTT (gain 1/4): one late pong does not swing the prediction.
        s->rttMs = s->rttMs < 0.0 ? rtt : 0.75 * s->rttMs + 0.25 * rtt;
    }

    void onMessage(const SessionPtr& s, std::vector<uint8_t>&& bytes, bool binary) {
        SessionState state;
        {
            std::lock_guard lock(mutex);
            state = s->state;
            s->lastHeard = Clock::now();
        }
        if (state == SessionState::kClosed) return;
        if (!binary) return fail(s, ErrorKind::kProtocol, "text message (binary messages only)");
        if (!mayBeSentBy(bytes, Peer::kClient))
            return fail(
                s, ErrorKind::kProtocol,
                fmt::format("unexpected {} from a client", messageTypeName(MessageType(bytes[0]))));
        DecodeLimits limits;
        auto m = decodeMessage(bytes, limits);
        if (!m) return fail(s, ErrorKind::kProtocol, m.status().message());
        if (state == SessionState::kAwaitingHello) {
            if (auto* hello = std::get_if<ClientHello>(&*m)) return onHello(s, *hello);
            return fail(s, ErrorKind::kProtocol,
                        fmt::format("{} before ClientHello", messageTypeName(messageType(*m))));
        }
        if (auto* pose = std::get_if<PoseMessage>(&*m)) return onPose(s, *pose);
        if (auto* ping = std::get_if<Ping>(&*m)) return onPing(s, *ping);
        if (auto* pong = std::get_if<Pong>(&*m)) return onPong(s, *pong);
        if (std::holds_alternative<Bye>(*m)) return closeQuietly(s, "client said goodbye");
        if (auto* error = std::get_if<ErrorMessage>(&*m))
            return closeQuietly(s, "client error: " + printable(error->text, kMaxTextBytes));
        fail(s, ErrorKind::kProtocol,
             fmt::format("{} after the session began", messageTypeName(messageType(*m))));
    }

    // The client said Bye (or sent an Error): closed without a word.
    void closeQuietly(const SessionPtr& s, const std::string& reason) {
        {
            std::lock_guard lock(mutex);
            if (s->state == SessionState::kAccepted) --stats.sessionsActive;
            s->state = SessionState::kClosed;
            if (s->endReason.empty()) s->endReason = reason;
        }
        s->conn->close();
    }

    void onClosed(const SessionPtr& s, const Status& why) {
        SessionEvent ended;
        {
            std::lock_guard lock(mutex);
            if (isWriteStall(why)) ++stats.writeStalls;
            // A message over the size limit, refused by the transport before allocation (close
            // 1009, docs/remote-protocol.md: Error kTooLarge), or a frame that breaks the
            // WebSocket protocol (close 1002) is the peer's protocol error.
            const bool peerError =
                s->state != SessionState::kClosed &&
                (why.code() == ErrorCode::kOutOfRange || why.code() == ErrorCode::kCorruptData);
            if (peerError) ++stats.protocolErrors;
            const bool beforeHello = s->state == SessionState::kAwaitingHello;
            if (s->state == SessionState::kAccepted) --stats.sessionsActive;
            s->state = SessionState::kClosed;
            s->pending.reset();
            sessions.erase(s);
            wake.notify_all();
            if (!config.onSessionEvent) return;
            if (peerError && beforeHello) {
                ended = eventOf(SessionEvent::Kind::kRefused, *s, "error: " + why.message());
            } else {
                if (!s->accepted) return;
                ended = eventOf(SessionEvent::Kind::kEnded, *s,
                                !s->endReason.empty() ? s->endReason
                                : isWriteStall(why)   ? "stopped reading"
                                : why.isOk()          ? "closed by the client"
                                                      : why.message());
                ended.durationS = msSince(s->connectedAt) * 1e-3;
                ended.setsSent = s->setsSent;
                ended.bytesSent = s->bytesSent;
            }
        }
        report(ended);
    }

    ConnectionEvents accept(std::shared_ptr<Connection> conn) {
        auto s = std::make_shared<Session>();
        s->conn = std::move(conn);
        {
            std::lock_guard lock(mutex);
            if (stopping) {
                s->conn->abort();
                return {};
            }
            sessions.insert(s);
            s->number = ++connections;
        }
        ConnectionEvents ev;
        ev.onMessage = [this, s](std::vector<uint8_t>&& m, bool binary) {
            onMessage(s, std::move(m), binary);
        };
        ev.onClosed = [this, s](const Status& why) { onClosed(s, why); };
        return ev;
    }

    // The worker: renders for ready sessions in turn and pings every session periodically.
    void run() {
        warp::ReferenceSet set;
        std::unique_lock lock(mutex);
        while (!stopping) {
            wake.wait_for(lock, std::chrono::milliseconds(50),
                          [&] { return stopping || (!ready.empty() && queueHasRoomLocked()); });
            if (stopping) break;
            housekeepLocked();
            if (ready.empty() || !queueHasRoomLocked()) continue;
            SessionPtr s = ready.front();
            ready.pop_front();
            s->ready = false;
            if (s->state != SessionState::kAccepted || !s->pending) continue;
            PoseMessage pose = *s->pending;
            s->pending.reset();
            s->inFlight = true;
            // The set reaches the client about one RTT after the pose left it, plus the time the
            // pose waited here and the render and encode ahead.
            double leadMs =
                std::max(0.0, s->rttMs) + msSince(s->pendingAt) + renderEncodeMsEstimate;
            Vec3 velocity = pose.hasVelocity ? pose.velocity : s->estimatedVelocity;
            const int faceSize = s->faceSize;
            const uint32_t sequence = s->sequence++;
            lock.unlock();
            serve(s, pose, velocity, leadMs, faceSize, sequence, &set);
            lock.lock();
        }
    }

    // Whether all sessions' queued sets leave room for another render (maxQueuedSetBytes);
    // counts each time renders start to wait.
    bool queueHasRoomLocked() {
        const bool room = setBytesQueued < config.maxQueuedSetBytes;
        if (!room && !ready.empty() && !waitingForQueue) ++stats.queueWaits;
        waitingForQueue = !room && !ready.empty();
        return room;
    }

    void serve(const SessionPtr& s, const PoseMessage& pose, Vec3 velocity, double leadMs,
               int faceSize, uint32_t sequence, warp::ReferenceSet* set) {
        warp::Pose at = pose.pose;
        if (config.prediction == Prediction::kConstantVelocity)
            at.eye = predictEye(at.eye, velocity, leadMs);
        warp::ReferenceSetOptions options = config.reference;
        options.faceSize = faceSize;
        if (config.fitClipPlanes)
            scene::clipPlanesFor(scene->bounds(), at.eye, &options.nearPlane, &options.farPlane);
        Clock::time_point start = Clock::now();
        Status rendered = warp::renderReferenceSet(*renderer, *scene, at, options, set);
        const double renderMs = msSince(start);
        if (!rendered) return fail(s, ErrorKind::kInternal, rendered.message());
        Clock::time_point encodeStart = Clock::now();
        Message m = ReferenceSetMessage{sequence, pose.timestampUs, std::move(*set)};
        CodecOptions codec = config.codec;
        {
            std::lock_guard lock(mutex);
            codec.disparity = s->disparityCodec;
        }
        auto bytes = encodeMessage(m, codec);
        *set = std::move(std::get<ReferenceSetMessage>(m).set);  // keep the buffers
        const double encodeMs = msSince(encodeStart);
        if (!bytes) return fail(s, ErrorKind::kInternal, bytes.status().message());
        const size_t size = bytes->size();
        int64_t raw = 0;
        for (const warp::ReferenceView& v : set->views) raw += int64_t(v.color.pixelCount()) * 8;
        {
            std::lock_guard lock(mutex);
            stats.renderMsMean += (renderMs - stats.renderMsMean) / double(stats.setsSent + 1);
            stats.encodeMsMean += (encodeMs - stats.encodeMsMean) / double(stats.setsSent + 1);
            renderEncodeMsEstimate =
                renderEncodeMsEstimate == 0.0
                    ? renderMs + encodeMs
                    : 0.75 * renderEncodeMsEstimate + 0.25 * (renderMs + encodeMs);
            stats.maxSetBytes = std::max(stats.maxSetBytes, size);
            setBytesQueued += size;
        }
        s->conn->send(std::move(bytes).value(), [this, s, size, raw](const Status& written) {
            std::lock_guard lock(mutex);
            if (written) {
                ++stats.setsSent, stats.bytesSent += int64_t(size), stats.rawBytesSent += raw;
                ++s->setsSent, s->bytesSent += int64_t(size);
            }
            s->inFlight = false;
            setBytesQueued -= size;
            scheduleLocked(s);  // backpressure: the next render only after this write
            wake.notify_one();  // renders waiting for the queue may go on
        });
        std::lock_guard lock(mutex);
        size_t queued = 0;
        for (const SessionPtr& other : sessions) queued += other->conn->queuedBytes();
        stats.maxQueuedBytes = std::max(stats.maxQueuedBytes, queued);
    }

    // Pings accepted sessions every pingIntervalMs; drops connections that never said hello;
    // ends sessions that stay silent (idleTimeoutMs); gives a session that stays without a pose
    // its first set (kInitialSetAfterMs).
    void housekeepLocked() {
        Clock::time_point now = Clock::now();
        std::vector<SessionPtr> ping, drop, idle;
        for (const SessionPtr& s : sessions) {
            if (s->state == SessionState::kAccepted && !s->lastPose && !s->pending &&
                !s->initialQueued && initialPose && msSince(s->connectedAt) > kInitialSetAfterMs) {
                s->initialQueued = true;
                s->pending = PoseMessage{0, *initialPose, false, Vec3(0.0f)};
                s->pendingAt = now;
                scheduleLocked(s);
            }
            if (s->state == SessionState::kAwaitingHello &&
                msSince(s->connectedAt) > kHelloTimeoutMs)
                drop.push_back(s);
            if (s->state == SessionState::kAccepted &&
                msSince(s->lastHeard) > config.idleTimeoutMs) {
                idle.push_back(s);
                continue;
            }
            if (s->state == SessionState::kAccepted &&
                std::chrono::duration<double, std::milli>(now - s->lastPingSent).count() >=
                    config.pingIntervalMs) {
                s->lastPingSent = now;
                ++s->pingNonce;
                ping.push_back(s);
            }
        }
        for (const SessionPtr& s : drop) s->state = SessionState::kClosed, s->conn->abort();
        for (const SessionPtr& s : ping) s->pings.send(*s->conn, Ping{nowUs(), s->pingNonce});
        for (const SessionPtr& s : idle) {
            --stats.sessionsActive;
            ++stats.idleTimeouts;
            s->state = SessionState::kClosed;
            s->endReason =
                fmt::format("idle: no message for {:.1f} s", config.idleTimeoutMs / 1000.0);
            send(s, Bye{ByeReason::kIdleTimeout, s->endReason});
            s->conn->close();
        }
    }
};

Server::Server(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
Server::~Server() {
    stop();
}

Result<std::unique_ptr<Server>> Server::create(scene::Scene scene, const ServerConfig& config) {
    return create(std::make_shared<const scene::Scene>(std::move(scene)), config);
}

Result<std::unique_ptr<Server>> Server::create(std::shared_ptr<const scene::Scene> scene,
                                               const ServerConfig& config) {
    if (!scene) return errorStatus(ErrorCode::kInvalidArgument, "server: no scene");
    PLX_RETURN_IF_ERROR(checkServerConfig(config));
    auto impl = std::make_unique<Impl>();
    impl->scene = std::move(scene);
    impl->config = config;
    impl->initialPose = poseAt(scene::defaultViewpoint(*impl->scene));
    auto renderer = raster::Renderer::create({config.renderThreads});
    if (!renderer) return renderer.status();
    impl->renderer = std::move(renderer).value();
    auto transport = Transport::create();
    if (!transport) return transport.status();
    impl->transport = std::move(transport).value();
    ConnectionConfig cc;
    cc.maxMessageBytes = kMaxClientMessageBytes;
    cc.link = config.link;
    cc.writeStallTimeoutMs = config.writeStallTimeoutMs;
    cc.maxPendingConnections = config.maxPendingConnections;
    cc.httpFiles = config.pages;
    Impl* p = impl.get();
    auto port = impl->transport->listen(
        config.bind, config.port, cc, [p](std::shared_ptr<Connection> c) { return p->accept(c); });
    if (!port) return port.status();
    impl->port = *port;
    impl->worker = std::thread([p] { p->run(); });
    return std::unique_ptr<Server>(new Server(std::move(impl)));
}

int Server::port() const {
    return mImpl->port;
}

ServerStats Server::stats() const {
    std::lock_guard lock(mImpl->mutex);
    ServerStats s = mImpl->stats;
    s.queuedBytes = 0;
    for (const SessionPtr& session : mImpl->sessions) s.queuedBytes += session->conn->queuedBytes();
    const Transport::ListenerStats listener = mImpl->transport->listenerStats();
    s.acceptFailures = listener.acceptFailures;
    s.pendingDropped = listener.pendingDropped;
    return s;
}

void Server::stop() {
    Impl& m = *mImpl;
    std::vector<SessionPtr> open;
    {
        std::lock_guard lock(m.mutex);
        if (m.stopped) return;
        m.stopped = m.stopping = true;
        m.wake.notify_all();
        open.assign(m.sessions.begin(), m.sessions.end());
    }
    if (m.worker.joinable()) m.worker.join();
    m.transport->stopListening();
    for (const SessionPtr& s : open) {
        {
            std::lock_guard lock(m.mutex);
            if (s->state != SessionState::kAccepted) continue;
            s->endReason = "server stopping";
        }
        m.send(s, Bye{ByeReason::kGoingAway, "server shutting down"});
        s->conn->close();
    }
    // Wait for the goodbyes to be written and the peers to close (bounded).
    std::unique_lock lock(m.mutex);
    m.wake.wait_for(lock, std::chrono::seconds(1), [&] { return m.sessions.empty(); });
    lock.unlock();
    m.transport->stop();
    lock.lock();
    m.sessions.clear();
    m.ready.clear();
}

}  // namespace plx::remote
