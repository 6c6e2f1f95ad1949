#pragma once
// WebSocket transport for remote sessions (docs/remote-protocol.md, "Framing"): binary messages
// over TCP, with optional link emulation (latency, jitter, bandwidth) on the real socket. The
// implementation (Boost.Beast) stays in transport.cpp; this header has no Boost in it.
//
// Threading: a Transport owns one I/O thread. Every callback (ConnectionEvents, send completions)
// runs on it, so callbacks must be short and must not block. Connection methods may be called
// from any thread.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <stop_token>
#include <string>
#include <string_view>
#include <vector>

#include <plx/core/status.h>

namespace plx::remote {

// A link emulated on one side's socket, in both directions: each message written is released
// after latency plus a uniform jitter in [0, jitterMs], paced by a token bucket at bandwidthMbit
// (its serialisation time); each message read is delayed the same way before it is delivered.
// Order is preserved both ways. Over loopback, latency L on the server gives a round trip of 2L.
struct LinkEmulation {
    double latencyMs = 0.0;      // one-way, 0..10000
    double jitterMs = 0.0;       // 0..10000, added to latency per message
    double bandwidthMbit = 0.0;  // 0: unlimited; else > 0.001
    uint32_t seed = 1;           // jitter's random sequence
    bool active() const { return latencyMs > 0.0 || jitterMs > 0.0 || bandwidthMbit > 0.0; }
};
Status checkLinkEmulation(const LinkEmulation& link);

// Whether `bind` is an IPv4 or IPv6 address a listener can bind (Transport::listen); the error
// names it.
Status checkBindAddress(const std::string& bind);
// Whether `source` is empty or an IP address of this host a client can connect from
// (ConnectionConfig::sourceAddress): it is bound once, to a free port, and let go; the error
// names it.
Status checkSourceAddress(const std::string& source);

// The group a peer address counts in for the per-address limits (ServerConfig::
// maxSessionsPerAddress, ConnectionConfig::maxPendingConnections): an IPv4 address is its own,
// an IPv6 address its /64 ("2001:db8:1:2::/64"), since one IPv6 client commonly holds a whole
// /64 and could otherwise spread over as many addresses as it likes. Text that is no IP address
// is its own group.
std::string addressGroup(std::string_view address);

// A file a listener serves to plain HTTP GET requests on its port: the browser page.
struct HttpFile {
    std::span<const uint8_t> bytes;  // must outlive the listener (embedded assets do)
    std::string contentType;
    // Sent with it besides the transport's own (Content-Type, X-Content-Type-Options: nosniff,
    // Cache-Control: no-cache), e.g. a Content-Security-Policy.
    std::vector<std::pair<std::string, std::string>> headers;
};
// Looks up the file of a request's path ("/", "/main.js"; query and fragment already stripped);
// nullopt answers 404. It never touches the file system unless its author makes it.
using HttpFiles = std::function<std::optional<HttpFile>(std::string_view path)>;

struct ConnectionConfig {
    // The WebSocket layer refuses (closes with code 1009) any message larger than this before
    // allocating it: the largest message the peer may send by docs/remote-protocol.md.
    size_t maxMessageBytes = 2048;
    LinkEmulation link;
    double handshakeTimeoutMs = 5000.0;
    // A peer that stops reading is dropped: messages are written in frames of at most
    // kWriteChunkBytes, and a frame the socket has not taken within this time closes the
    // connection (isWriteStall says so of its status). Progress is timed, not a message's whole
    // time; the socket takes bytes again once the peer has read a part of its buffer (Linux: a
    // third, up to about 1.4 MB), so only a peer reading less than that per timeout is cut.
    double writeStallTimeoutMs = 30000.0;
    // Listeners only: connections accepted that are pending, awaiting their first message (the
    // HTTP request, WebSocket handshake or first message still to come) or their close (a
    // refusal or goodbye written, the peer's close awaited), at most this many; one more drops
    // the oldest of them from the peer address that has the most. A flood of peers that say
    // nothing, or are refused and never read it, then holds neither the file descriptors nor the
    // timeouts' worth of time that new clients need, and a flood from one address drops only
    // its own connections (checkMaxPending).
    int maxPendingConnections = 64;
    // Listeners only: requests that are not a WebSocket upgrade are answered from these files
    // (404 when empty), then the connection is closed.
    HttpFiles httpFiles;
    // Connections made by connect only: the local IP address the socket is bound to before it
    // connects (a multi-homed host's interface, or one of loopback's 127.0.0.0/8), so that the
    // server sees the client from it; the host's first address of that family is used (an
    // IPv4-mapped ::ffff:a.b.c.d counts as IPv4). Empty: the system's choice.
    std::string sourceAddress;
    // Connections made by connect only: a stop requested here ends the connect at once (a
    // client that stops while its server is slow to answer). No state: never.
    std::stop_token cancel;
};

// The largest frame a connection writes: a longer message goes out as several frames (RFC 6455
// fragmentation), each a unit of progress for ConnectionConfig::writeStallTimeoutMs.
inline constexpr size_t kWriteChunkBytes = 64 * 1024;
Status checkWriteStallTimeout(double ms);  // 100 ms .. 1 hour

Status checkMaxPending(int connections);  // 1..65536

// Whether a connection closed because its peer stopped reading (writeStallTimeoutMs).
bool isWriteStall(const Status& why);

// What one connection reports, on the transport's I/O thread.
struct ConnectionEvents {
    // A whole message. binary = false for a text message (a protocol error for Parallax).
    std::function<void(std::vector<uint8_t>&& message, bool binary)> onMessage;
    // Once, when the connection is gone (closed by either side, reset, or the peer's violation);
    // the status says why: ok for a clean WebSocket close, kOutOfRange for a message over
    // maxMessageBytes (close 1009), kCorruptData for a frame that breaks RFC 6455 (close 1002).
    std::function<void(const Status& why)> onClosed;
};

// One WebSocket connection. Methods are thread-safe.
class Connection {
public:
    virtual ~Connection() = default;
    // Queues one binary message; `done` runs on the I/O thread once the socket accepted all of
    // it (or with the error that stopped it). Queued messages keep their order.
    virtual void send(std::vector<uint8_t> message,
                      std::function<void(const Status&)> done = nullptr) = 0;
    // Bytes queued by send and not yet accepted by the socket.
    virtual size_t queuedBytes() const = 0;
    // Stops or resumes reading (a stalled reader, for tests and backpressure).
    virtual void setReading(bool on) = 0;
    // A clean WebSocket close once every queued message is written.
    virtual void close() = 0;
    // Drops the TCP connection at once (no close handshake).
    virtual void abort() = 0;
    // The peer's IP address as text ("127.0.0.1", "::1"; an IPv4-mapped IPv6 address as the
    // IPv4 one), read when the TCP connection was made; empty when the socket could not say.
    virtual std::string peerAddress() const = 0;
    // addressGroup(peerAddress()), computed once.
    virtual std::string peerGroup() const = 0;
};

// One I/O thread with its listeners and connections. It must outlive every Connection it made
// (release them before destroying it); stop() drops the ones still open.
class Transport {
public:
    static Result<std::unique_ptr<Transport>> create();
    ~Transport();

    // Accepts WebSocket connections on bind:port (port 0: a free one) and returns the bound
    // port. onAccept receives each connection after its WebSocket handshake and returns its
    // events; reading starts after it returns. Errors: a bad address, a port in use.
    using AcceptHandler = std::function<ConnectionEvents(std::shared_ptr<Connection>)>;
    Result<int> listen(const std::string& bind, int port, const ConnectionConfig& config,
                       AcceptHandler onAccept);
    // Stops accepting (connections already made go on).
    void stopListening();

    // What the listener met since it started: accepts that failed (out of file descriptors or
    // memory) and connections dropped by ConnectionConfig::maxPendingConnections.
    struct ListenerStats {
        int64_t acceptFailures = 0;
        int64_t pendingDropped = 0;
    };
    ListenerStats listenerStats() const;

    // Connects to ws://host:port/path (from config.sourceAddress when set) and completes the
    // WebSocket handshake, each step (name resolution, TCP, handshake) waiting at most
    // config.handshakeTimeoutMs. Errors: unreachable, refused, timed out, cancelled; a source
    // address that is not an IP address, not local, or of a family
    // the host has no address of.
    Result<std::shared_ptr<Connection>> connect(const std::string& host, int port,
                                                const std::string& path,
                                                const ConnectionConfig& config,
                                                ConnectionEvents events);

    // Stops the I/O thread: connections still open are dropped. Idempotent.
    void stop();

private:
    struct Impl;
    explicit Transport(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

// "ws://host:port/path" split; errors name the problem (only ws:// is supported). An IPv6
// address goes in brackets, as RFC 3986 writes it ("ws://[::1]:8080/"; the host is then "::1").
struct WsUrl {
    std::string host;
    int port = 80;
    std::string path = "/";
};
Result<WsUrl> parseWsUrl(const std::string& url);

// HOST:PORT as a URL and the Host header write it: an IPv6 address in brackets ("[::1]:8080").
std::string authority(const std::string& host, int port);

}  // namespace plx::remote
