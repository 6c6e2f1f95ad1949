#pragma once
// The render server of Mark, Bishop, McMillan ("The Remote Rendering System"): one session per
// WebSocket client (docs/remote-protocol.md). A session receives timestamped poses, predicts
// where the viewer will be when the reference set arrives ("Prediction techniques": constant
// velocity), renders the set there, encodes it and sends it.
//
// Bounded by construction: a session keeps one pose (a newer one replaces an unserved one) and
// at most one encoded set queued on its socket; the next render for it starts only after the
// previous set was written (backpressure). A slow client gets fewer, fresher sets. All sessions'
// queued sets together stay within ServerConfig::maxQueuedSetBytes (plus one set).

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include <plx/core/status.h>
#include <plx/remote/codec.h>
#include <plx/remote/transport.h>
#include <plx/scene/scene.h>
#include <plx/warp/warp.h>

namespace plx::remote {

// How the server moves the eye from the pose it received to the one it renders for.
enum class Prediction {
    kNone,              // render at the received pose
    kConstantVelocity,  // eye + velocity * lead (velocity from the pose, else from the last two)
};
Result<Prediction> parsePrediction(const std::string& name);  // none, velocity
const char* predictionName(Prediction prediction);

// One entry of the server's session log (ServerConfig::onSessionEvent): a client's hello
// accepted or refused, and an accepted session's end.
struct SessionEvent {
    enum class Kind { kAccepted, kRefused, kEnded };
    Kind kind = Kind::kAccepted;
    uint64_t session = 0;  // the connection's number since the server started: 1, 2, ...
    std::string address;   // the peer's (Connection::peerAddress)
    int faceSize = 0;      // kAccepted: the face size it is served
    // kRefused: why (the reason its ServerHello or Error carried). kEnded: how it ended: "client
    // said goodbye", "closed by the client", "stopped reading" (writeStallTimeoutMs), "server
    // stopping", or the error the server sent or the connection met.
    std::string reason;
    double durationS = 0.0;               // kEnded: since its connection was accepted
    int64_t setsSent = 0, bytesSent = 0;  // kEnded: the reference sets written to it
};
const char* sessionEventName(SessionEvent::Kind kind);  // accepted, refused, ended

struct ServerConfig {
    std::string bind = "127.0.0.1";  // listen on loopback unless told otherwise
    int port = 8080;                 // 0: a free port (Server::port says which)
    std::string token;               // non-empty: ClientHello must carry exactly this token
    // What a set holds: layout, clip planes, shading. faceSize is the largest the server renders;
    // a session gets min(requested, maxServedFaceSize(reference)).
    warp::ReferenceSetOptions reference;
    // Near and far planes fitted to the scene's bounds from each rendered eye (clipPlanesFor);
    // false: reference.nearPlane and farPlane as given.
    bool fitClipPlanes = true;
    CodecOptions codec;
    int maxSessions = 16;  // accepted sessions at once, 1..1024; more get Error kOverloaded
    // Accepted sessions from one peer address (an IPv6 peer's /64: addressGroup) at once,
    // 1..1024; more get Error kOverloaded. 0: no such limit (the default: behind a proxy or a NAT
    // every client has the same address).
    int maxSessionsPerAddress = 0;
    int poseRateHz = 60;   // announced in ServerHello, 1..1000
    LinkEmulation link;    // applied to every connection, both directions
    Prediction prediction = Prediction::kConstantVelocity;
    int renderThreads = 0;          // the renderer's threads (0: all cores)
    double pingIntervalMs = 500.0;  // the server pings each session this often (its RTT)
    // A session whose socket takes no frame of kWriteChunkBytes in this long is dropped: its peer
    // stopped reading and would hold one of maxSessions for as long as it stays connected.
    double writeStallTimeoutMs = 30000.0;
    // A session whose client sends nothing in this long, no Pose, Ping or Pong, though the
    // server pings it every pingIntervalMs, is ended with Bye kIdleTimeout ("idle: ..."): its peer
    // is gone, or holds one of maxSessions while it reads and answers nothing. 1..3600 s, and
    // above twice pingIntervalMs.
    double idleTimeoutMs = 30000.0;
    // Connections without a session, that have not said ClientHello yet (nor finished their
    // WebSocket handshake or HTTP request) or are being closed (refused, failed, said goodbye),
    // at most this many: one more drops the oldest of the address with the most
    // (ConnectionConfig's).
    int maxPendingConnections = 64;
    // All sessions' encoded sets handed to their sockets and not yet written, at most this many
    // bytes plus one set: past it, renders wait for writes. Bounds the server's memory whatever
    // maxSessions and the clients' links (each session queues one set at most); >= 1.
    size_t maxQueuedSetBytes = size_t(256) << 20;
    // Plain HTTP GET on the same port: the browser client's page (`parallax serve` passes the
    // assets embedded in the binary); empty: every such request gets 404.
    HttpFiles pages;
    // The session log: called for each SessionEvent on the transport's I/O thread (one at a
    // time, a session's in order), without the server's lock; it must return quickly. Empty: none.
    std::function<void(const SessionEvent&)> onSessionEvent;
};
Status checkServerConfig(const ServerConfig& config);

// The largest face size a server renders for `reference`: its faceSize, lowered for a wide view
// so that the view's width, faceSize x wideAspect, stays within what decoders take
// (DecodeLimits::maxViewSide, 4096): a wider view would reach no client.
int maxServedFaceSize(const warp::ReferenceSetOptions& reference);

struct ServerStats {
    int64_t sessionsActive = 0;  // accepted (handshake done) and open
    int64_t sessionsTotal = 0;   // accepted since start
    int64_t refused = 0;         // refused at the handshake (version, token, overloaded)
    int64_t protocolErrors = 0;  // sessions closed with Error kProtocol or kTooLarge, or by a
                                 // WebSocket protocol violation
    int64_t writeStalls = 0;     // sessions dropped because their peer stopped reading
    int64_t idleTimeouts = 0;    // sessions ended because their client sent nothing (idleTimeoutMs)
    int64_t queueWaits = 0;      // times renders waited for maxQueuedSetBytes
    int64_t pendingDropped = 0;  // connections dropped by maxPendingConnections
    int64_t acceptFailures = 0;  // accepts that failed (out of file descriptors)
    int64_t setsSent = 0;        // reference sets written to sockets
    int64_t bytesSent = 0;       // their bytes
    int64_t rawBytesSent = 0;    // 8 bytes (RGBA8 + f32) per pixel of those sets
    size_t queuedBytes = 0;      // now: bytes accepted by sessions' sockets' queues, not written
    size_t maxQueuedBytes = 0;   // the most queuedBytes ever seen (sampled at each send)
    size_t maxSetBytes = 0;      // the largest encoded set
    double renderMsMean = 0.0, encodeMsMean = 0.0;  // per set
};

class Server {
public:
    // Listens and starts serving `scene` (moved in). Errors: checkServerConfig's, the address.
    static Result<std::unique_ptr<Server>> create(scene::Scene scene, const ServerConfig& config);
    // The same for a scene the caller shares (unchanged while the server runs), so that servers
    // one after another serve one scene without a copy each. Errors: also a null scene.
    static Result<std::unique_ptr<Server>> create(std::shared_ptr<const scene::Scene> scene,
                                                  const ServerConfig& config);
    ~Server();  // stop()

    int port() const;
    ServerStats stats() const;
    // Says Bye(GoingAway) to every session, waits for those bytes (at most ~1 s), then closes.
    // Idempotent.
    void stop();

private:
    struct Impl;
    explicit Server(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

// The eye a constant-velocity predictor renders for: eye + velocity * leadMs, the lead clamped
// to 0..1000 ms (past a second the prediction is worse than none, Mark et al. citing Azuma).
Vec3 predictEye(const Vec3& eye, const Vec3& velocity, double leadMs);

}  // namespace plx::remote
