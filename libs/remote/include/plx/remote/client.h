#pragma once
// The warping client's network side (Mark, Bishop, McMillan, "The Remote Rendering System"): an
// I/O thread that keeps a session with a render server, sends the newest head pose (with its
// velocity) at the server's pose rate and pings, and receives reference sets; a decode thread
// decodes the newest received set (one that arrives while another decodes replaces any still
// waiting). The display loop (the caller) takes the newest set whenever it likes and never
// waits for the network. When the server goes away the client reconnects with exponential
// backoff and keeps the last set meanwhile. A server that breaks the protocol is told so and
// the session retried: a message of the client's side, a set before an accepted ServerHello or
// beyond what it announced (announcedLimits), a second ServerHello, a set whose sequence does
// not increase or that answers a pose sent after it arrived. Pongs that echo no ping sent are
// not round trips.

#include <cstdint>
#include <memory>
#include <string>

#include <plx/core/status.h>
#include <plx/remote/codec.h>
#include <plx/remote/protocol.h>
#include <plx/warp/warp.h>

namespace plx::remote {

struct ClientConfig {
    std::string host = "127.0.0.1";
    int port = 8080;
    std::string path = "/";
    std::string token;
    warp::ReferenceLayout layout = warp::ReferenceLayout::kCube4;
    int faceSize = 512;  // requested; the server may lower it
    DecodeLimits limits;  // the largest sets taken; each session's ServerHello narrows them
    double pingIntervalMs = 500.0;
    // A session whose server sends nothing in this long (it answers pings every pingIntervalMs
    // and pings on its own) is ended and retried: the server is gone, or stuck.
    double silenceTimeoutMs = 30000.0;
    // Reconnection backoff: first wait, doubled per failed attempt up to the cap.
    double backoffMinMs = 100.0, backoffMaxMs = 2000.0;
    double connectTimeoutMs = 3000.0;
    // The local address to connect from (ConnectionConfig::sourceAddress); empty: the system's.
    std::string sourceAddress;
};

// A decoded set with what the client knows about it.
struct ReceivedSet {
    warp::ReferenceSet set;
    uint32_t sequence = 0;
    uint64_t requestTimestampUs = 0;  // the pose's timestamp (client clock, clientNowUs)
    uint64_t arrivalUs = 0;           // when its message arrived (client clock)
    size_t bytes = 0;                 // the message's bytes
};

struct ClientStats {
    int64_t referencesReceived = 0;  // sets decoded and offered by newest()
    int64_t bytesReceived = 0;       // their messages' bytes
    int64_t referencesDropped = 0;   // sets replaced by a newer one before their decode began
    int64_t connects = 0;            // successful handshakes (1 + reconnections)
    int64_t posesSent = 0;
    double rttMs = -1.0;  // smoothed ping round trip; < 0 before the first Pong
    double decodeMsMean = 0.0;
    size_t queuedBytes = 0;  // now: bytes this side has queued on the socket, not yet written
    bool connected = false;
    int faceSize = 0, poseRateHz = 0;  // from the last ServerHello
    // Why the latest connection that failed did (not connected, or closed by an error); empty
    // while none has.
    std::string lastError;
};

// The client's clock, microseconds (the clock of Pose timestamps).
uint64_t clientNowUs();

class Client {
public:
    // Starts the I/O thread, which connects in the background. Errors: bad config.
    static Result<std::unique_ptr<Client>> create(const ClientConfig& config);
    ~Client();  // stop()

    // The pose to send next (the newest wins); timestampUs on clientNowUs's clock.
    void setPose(const PoseMessage& pose);
    // The newest decoded set, or null before the first.
    std::shared_ptr<const ReceivedSet> newest() const;
    // Waits until a set has arrived, the client failed for good, or timeoutMs passed.
    bool waitForFirst(double timeoutMs) const;
    // A failure the client will not retry (refused at the handshake); ok otherwise.
    Status fatal() const;
    ClientStats stats() const;
    // Says Bye and stops the I/O thread. Idempotent.
    void stop();

private:
    struct Impl;
    explicit Client(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

}  // namespace plx::remote
