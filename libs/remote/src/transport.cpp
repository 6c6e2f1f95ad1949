// The WebSocket transport on Boost.Beast (asynchronous, one I/O thread per Transport). The only
// translation unit that includes Beast and Asio: they cost ~17 s and 700 MB to compile.

#include <plx/remote/transport.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <future>
#include <mutex>
#include <random>
#include <set>
#include <string_view>
#include <thread>
#include <tuple>
#include <unordered_map>

#include <fmt/format.h>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace plx::remote {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace http = beast::http;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using ErrorCodeB = boost::system::error_code;

Status checkLinkEmulation(const LinkEmulation& link) {
    auto bad = [](const char* what, double v) {
        return errorStatus(ErrorCode::kInvalidArgument, fmt::format("{} {} out of range", what, v));
    };
    if (!(link.latencyMs >= 0.0 && link.latencyMs <= 10000.0))
        return bad("latency", link.latencyMs);
    if (!(link.jitterMs >= 0.0 && link.jitterMs <= 10000.0)) return bad("jitter", link.jitterMs);
    if (!(link.bandwidthMbit == 0.0 || (link.bandwidthMbit >= 0.001 && link.bandwidthMbit <= 1e6)))
        return bad("bandwidth", link.bandwidthMbit);
    return Status::ok();
}

namespace {

constexpr std::string_view kWriteStallText = "peer stopped reading";

bool isGetOrHead(http::verb method) {
    return method == http::verb::get || method == http::verb::head;
}

// RFC 6455 section 4.2.1 item 5: a Sec-WebSocket-Key is 16 bytes in base64, 24 characters
// ending in "==". Beast checks only that one is present and not too long.
bool isWebSocketKey(std::string_view key) {
    auto base64 = [](char c) {
        return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
               c == '+' || c == '/';
    };
    return key.size() == 24 && key.ends_with("==") &&
           std::all_of(key.begin(), key.end() - 2, base64);
}

// One direction of an emulated link: a message of B bytes enters the wire when the previous one
// has left it (token bucket at the bandwidth: B * 8 / bandwidth seconds of serialisation), then
// travels latency + U(0, jitter); releases never overtake each other, so order is kept.
class LinkShaper {
public:
    LinkShaper(const LinkEmulation& link, uint32_t seed) : mLink(link), mRng(seed) {}

    Clock::time_point release(size_t bytes, Clock::time_point now) {
        using Ms = std::chrono::duration<double, std::milli>;
        Clock::time_point start = std::max(now, mWireFree);
        double serialiseMs =
            mLink.bandwidthMbit > 0.0 ? double(bytes) * 8.0 / (mLink.bandwidthMbit * 1e3) : 0.0;
        mWireFree = start + std::chrono::duration_cast<Clock::duration>(Ms(serialiseMs));
        double jitterMs = mLink.jitterMs > 0.0
                              ? std::uniform_real_distribution<double>(0.0, mLink.jitterMs)(mRng)
                              : 0.0;
        Clock::time_point out =
            mWireFree + std::chrono::duration_cast<Clock::duration>(Ms(mLink.latencyMs + jitterMs));
        mLastRelease = std::max(mLastRelease, out);
        return mLastRelease;
    }

private:
    LinkEmulation mLink;
    std::mt19937 mRng;
    Clock::time_point mWireFree{}, mLastRelease{};
};

// A listener's bind address or a client's source address (`what` names which).
Result<asio::ip::address> parseIpAddress(const std::string& text, const char* what) {
    ErrorCodeB ec;
    asio::ip::address address = asio::ip::make_address(text, ec);
    if (ec)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("{} '{}' is not an IP address", what, text));
    return address;
}

// An IPv4-mapped IPv6 address (::ffff:a.b.c.d) as the IPv4 address it names; others as they are.
asio::ip::address unmapped(const asio::ip::address& address) {
    if (address.is_v6() && address.to_v6().is_v4_mapped())
        return asio::ip::make_address_v4(asio::ip::v4_mapped, address.to_v6());
    return address;
}

// A peer's address as text; a dual-stack listener's IPv4 peers (::ffff:a.b.c.d) as IPv4, so that
// one peer has one name whichever socket it reached.
std::string addressText(const asio::ip::address& address) {
    return unmapped(address).to_string();
}

// A source address to bind (ConnectionConfig::sourceAddress): an IPv4-mapped one as IPv4, the
// family of the sockets that reach IPv4 hosts.
Result<asio::ip::address> parseSourceAddress(const std::string& text) {
    auto address = parseIpAddress(text, "source address");
    if (!address) return address.status();
    return unmapped(*address);
}

Status fromBoost(const ErrorCodeB& ec, const char* what) {
    if (!ec || ec == websocket::error::closed) return Status::ok();
    return errorStatus(ErrorCode::kIoError, fmt::format("{}: {}", what, ec.message()));
}

// Messages read but not yet delivered (only with link emulation): reading pauses above this, so
// a peer cannot grow the delay queue without bound.
constexpr size_t kMaxDelayedMessages = 64;

class WsConnection final : public Connection, public std::enable_shared_from_this<WsConnection> {
public:
    WsConnection(asio::io_context& io, tcp::socket socket, const ConnectionConfig& config)
        : mIo(io),
          mWs(std::move(socket)),
          mConfig(config),
          mSendTimer(io),
          mRecvTimer(io),
          mStallTimer(io),
          mOutShaper(config.link, config.link.seed),
          mInShaper(config.link, config.link.seed * 2654435761u + 1u) {
        mWs.binary(true);
        mWs.read_message_max(config.maxMessageBytes);
        mWs.auto_fragment(false);
        ErrorCodeB ec;
        const tcp::endpoint peer = beast::get_lowest_layer(mWs).socket().remote_endpoint(ec);
        if (!ec) tcpConnected(peer);  // accepted; a client's connects later (Transport::connect)
    }

    // Once the TCP connection is made, before the connection is shared (or while only the I/O
    // thread knows it): the peer's address, and no Nagle delay. Messages here are small and
    // timed (poses, pings, a refusal and its close): Nagle would hold one written while another
    // is unacknowledged until the peer's delayed ACK, up to 40 ms on Linux.
    void tcpConnected(const tcp::endpoint& peer) {
        mPeerAddress = addressText(peer.address());
        mPeerGroup = addressGroup(mPeerAddress);
        ErrorCodeB ignored;  // a socket that refuses the option still works, only later
        beast::get_lowest_layer(mWs).socket().set_option(tcp::no_delay(true), ignored);
    }

    websocket::stream<beast::tcp_stream>& ws() { return mWs; }

    // Server side: reads one HTTP request (headers at most kMaxRequestHeaderBytes, no body). A
    // WebSocket upgrade becomes a session (onUpgrade gives its events); anything else is answered
    // from config.httpFiles and closed.
    // `becamePending` runs when the connection turns pending again after its first message (a
    // refusal or goodbye written, the peer's close awaited): the listener's limit applies then
    // too, not only at its next accept.
    void acceptRequest(std::function<ConnectionEvents(std::shared_ptr<Connection>)> onUpgrade,
                       std::function<void()> becamePending) {
        mOnListener = mAwaitingFirst = true;
        mBecamePending = std::move(becamePending);
        mRequest.emplace();
        mRequest->header_limit(kMaxRequestHeaderBytes);
        mRequest->body_limit(0);
        beast::get_lowest_layer(mWs).expires_after(
            std::chrono::milliseconds(int64_t(std::max(1.0, mConfig.handshakeTimeoutMs))));
        http::async_read(mWs.next_layer(), mHttpBuffer, *mRequest,
                         [self = shared_from_this(), onUpgrade](ErrorCodeB ec, size_t) {
                             if (ec) return self->refuseUnreadRequest(ec);
                             const auto& req = self->mRequest->get();
                             if (websocket::is_upgrade(req) &&
                                 !isWebSocketKey(req[http::field::sec_websocket_key]))
                                 return self->answerStatus(
                                     http::status::bad_request,
                                     "Sec-WebSocket-Key is not 16 bytes in base64\n");
                             if (websocket::is_upgrade(req)) {
                                 beast::get_lowest_layer(self->mWs).expires_never();
                                 self->mWs.async_accept(self->mRequest->get(),
                                                        [self, onUpgrade](ErrorCodeB hec) {
                                                            if (hec)
                                                                return;  // a bad handshake: dropped
                                                            self->start(onUpgrade(self));
                                                        });
                                 return;
                             }
                             self->answerHttp();
                         });
    }

    void setTimeouts(bool server) {
        websocket::stream_base::timeout t = websocket::stream_base::timeout::suggested(
            server ? beast::role_type::server : beast::role_type::client);
        t.handshake_timeout =
            std::chrono::milliseconds(int64_t(std::max(1.0, mConfig.handshakeTimeoutMs)));
        beast::get_lowest_layer(mWs).expires_never();
        mWs.set_option(t);
    }

    // On the I/O thread, after the handshake.
    void start(ConnectionEvents events) {
        mEvents = std::move(events);
        mStarted = true;
        readMore();
    }

    // A message is handed over at once and taken onto the outbox on the I/O thread before
    // anything posted later runs: asio keeps no order between posts from different threads, and
    // a close() posted by another thread overtook a send() posted just before it on the I/O
    // thread (the client's Error to a server it refused was dropped, 3 runs in 8).
    void send(std::vector<uint8_t> message, std::function<void(const Status&)> done) override {
        mQueued += message.size();
        {
            std::lock_guard lock(mHandedOverMutex);
            mHandedOver.push_back({std::move(message), std::move(done)});
        }
        asio::post(mIo, [self = shared_from_this()] { self->takeHandedOver(); });
    }
    size_t queuedBytes() const override { return mQueued.load(); }
    void setReading(bool on) override {
        asio::post(mIo, [self = shared_from_this(), on] {
            self->mWantRead = on;
            self->readMore();
        });
    }
    void close() override {
        asio::post(mIo, [self = shared_from_this()] {
            self->takeHandedOver();  // what was sent before close() is written first
            const bool wasPending = self->pending();
            self->mCloseWhenDrained = true;
            self->pump();
            if (!wasPending && self->pending() && self->mBecamePending) self->mBecamePending();
        });
    }
    void abort() override {
        asio::post(mIo, [self = shared_from_this()] {
            ErrorCodeB ignored;
            beast::get_lowest_layer(self->mWs).socket().close(ignored);
            self->finish(errorStatus(ErrorCode::kIoError, "connection aborted"));
        });
    }
    std::string peerAddress() const override { return mPeerAddress; }
    std::string peerGroup() const override { return mPeerGroup; }
    const std::string& group() const { return mPeerGroup; }  // peerGroup, not copied

    // On the I/O thread: drops the socket (the transport stops, or too many are pending).
    void drop(std::string_view why) {
        ErrorCodeB ignored;
        beast::get_lowest_layer(mWs).socket().close(ignored);
        finish(errorStatus(ErrorCode::kIoError, std::string(why)));
    }

    // On the I/O thread: accepted by a listener and open, but no session's work: nothing
    // delivered yet (HTTP request, WebSocket handshake, first message), or being closed (a
    // refusal or a goodbye written, the peer's close awaited).
    bool pending() const {
        return mOnListener && !mFinished && (mAwaitingFirst || mCloseWhenDrained);
    }

private:
    static constexpr uint32_t kMaxRequestHeaderBytes = 8192;

    // A plain HTTP request: GET (or HEAD) of an embedded file, else 404 / 405; then close.
    void answerHttp() {
        const auto& req = mRequest->get();
        if (!isGetOrHead(req.method()))
            return answerStatus(http::status::method_not_allowed, "method not allowed\n");
        std::string_view target(req.target().data(), req.target().size());
        target = target.substr(0, target.find_first_of("?#"));
        std::optional<HttpFile> file;
        if (mConfig.httpFiles) file = mConfig.httpFiles(target);
        if (!file) return answerStatus(http::status::not_found, "not found\n");
        auto res = newResponse(http::status::ok, file->contentType);
        for (const auto& [name, value] : file->headers) res->set(name, value);
        res->body().assign(reinterpret_cast<const char*>(file->bytes.data()), file->bytes.size());
        writeAndClose(std::move(res));
    }

    // A request that could not be read: a peer that left or stayed silent is dropped; one whose
    // bytes broke HTTP or its limits hears why (RFC 9110 section 15.5), then the socket closes.
    void refuseUnreadRequest(ErrorCodeB ec) {
        if (ec == http::error::header_limit)
            return answerStatus(
                http::status::request_header_fields_too_large,
                fmt::format("request headers over {} bytes\n", kMaxRequestHeaderBytes));
        if (ec == http::error::body_limit)  // its start line was read
            return isGetOrHead(mRequest->get().method())
                       ? answerStatus(http::status::payload_too_large,
                                      "a request body is not taken\n")
                       : answerStatus(http::status::method_not_allowed, "method not allowed\n");
        const bool brokeHttp =
            ec.category() == http::make_error_code(http::error::bad_version).category() &&
            ec != http::error::end_of_stream && ec != http::error::partial_message;
        if (brokeHttp) return answerStatus(http::status::bad_request, "malformed request\n");
        dropSocket();
    }

    void answerStatus(http::status status, std::string text) {
        auto res = newResponse(status, "text/plain; charset=utf-8");
        if (status == http::status::method_not_allowed) res->set(http::field::allow, "GET, HEAD");
        res->body() = std::move(text);
        writeAndClose(std::move(res));
    }

    std::shared_ptr<http::response<http::string_body>> newResponse(http::status status,
                                                                   std::string_view type) {
        auto res = std::make_shared<http::response<http::string_body>>();
        res->result(status);
        res->version(11);
        res->keep_alive(false);
        res->set(http::field::server, "parallax");
        res->set("X-Content-Type-Options", "nosniff");
        res->set(http::field::cache_control, "no-cache");
        res->set(http::field::content_type, type);
        return res;
    }

    // Answers a HEAD with the headers a GET would have (RFC 9110 section 9.3.2).
    void writeAndClose(std::shared_ptr<http::response<http::string_body>> res) {
        res->prepare_payload();
        if (mRequest->get().method() == http::verb::head) {  // verb::unknown before a start line
            const size_t length = res->body().size();
            res->body().clear();
            res->content_length(length);
        }
        http::async_write(mWs.next_layer(), *res,
                          [self = shared_from_this(), res](ErrorCodeB ec, size_t) {
                              if (ec) return self->dropSocket();
                              ErrorCodeB ignored;
                              beast::get_lowest_layer(self->mWs).socket().shutdown(
                                  tcp::socket::shutdown_send, ignored);
                              self->drainThenClose(0);
                          });
    }

    // A lingering close: closing with request bytes unread would reset the connection, and the
    // peer's TCP stack could discard the answer before its reader sees it. The rest of the
    // request is read and dropped until the peer closes, at most kMaxLingerBytes or
    // handshakeTimeoutMs.
    void drainThenClose(size_t drained) {
        static constexpr size_t kMaxLingerBytes = size_t(1) << 22;
        if (drained == 0)
            beast::get_lowest_layer(mWs).expires_after(
                std::chrono::milliseconds(int64_t(std::max(1.0, mConfig.handshakeTimeoutMs))));
        if (drained > kMaxLingerBytes) return dropSocket();
        mHttpBuffer.clear();
        mWs.next_layer().async_read_some(
            mHttpBuffer.prepare(16384),
            [self = shared_from_this(), drained](ErrorCodeB ec, size_t n) {
                if (ec) return self->dropSocket();
                self->drainThenClose(drained + n);
            });
    }

    void dropSocket() {
        ErrorCodeB ignored;
        beast::get_lowest_layer(mWs).socket().shutdown(tcp::socket::shutdown_both, ignored);
        beast::get_lowest_layer(mWs).close();
    }

    std::optional<http::request_parser<http::empty_body>> mRequest;
    beast::flat_buffer mHttpBuffer;
    struct Outgoing {
        std::vector<uint8_t> bytes;
        std::function<void(const Status&)> done;
        Clock::time_point release;
        size_t written = 0;  // bytes of it the socket has taken (whole frames)
    };

    // On the I/O thread: the messages send() handed over, in their order.
    void takeHandedOver() {
        std::deque<HandedOver> taken;
        {
            std::lock_guard lock(mHandedOverMutex);
            taken.swap(mHandedOver);
        }
        for (HandedOver& h : taken) enqueue(std::move(h.bytes), std::move(h.done));
    }

    void enqueue(std::vector<uint8_t> m, std::function<void(const Status&)> done) {
        if (mFinished) {
            mQueued -= m.size();
            if (done) done(errorStatus(ErrorCode::kIoError, "connection closed"));
            return;
        }
        Clock::time_point release = mConfig.link.active()
                                        ? mOutShaper.release(m.size(), Clock::now())
                                        : Clock::time_point{};
        mOutbox.push_back({std::move(m), std::move(done), release});
        pump();
    }

    // Writes the outbox in order, each message when its emulated release time has come.
    void pump() {
        if (mWriting || mFinished) return;
        if (mOutbox.empty()) {
            if (mCloseWhenDrained && !mClosing) {
                mClosing = true;
                mWs.async_close(websocket::close_code::normal,
                                [self = shared_from_this()](ErrorCodeB ec) {
                                    self->finish(fromBoost(ec, "close"));
                                });
            }
            return;
        }
        mWriting = true;
        Outgoing& front = mOutbox.front();
        if (front.release > Clock::now()) {
            mSendTimer.expires_at(front.release);
            mSendTimer.async_wait([self = shared_from_this()](ErrorCodeB) {
                self->mWriting = false;
                if (self->mFinished || self->mOutbox.empty()) return;
                self->mOutbox.front().release = {};
                self->pump();
            });
            return;
        }
        writeFrame();
    }

    // Writes the next frame of the outbox's first message (at most kWriteChunkBytes) and times
    // it: a frame the socket has not taken within writeStallTimeoutMs means the peer stopped
    // reading, and only dropping it frees what it holds (a session slot, a queued set).
    void writeFrame() {
        Outgoing& front = mOutbox.front();
        const size_t n = std::min(kWriteChunkBytes, front.bytes.size() - front.written);
        const bool fin = front.written + n == front.bytes.size();
        const uint64_t frame = ++mFramesStarted;
        mStallTimer.expires_after(std::chrono::milliseconds(int64_t(mConfig.writeStallTimeoutMs)));
        mStallTimer.async_wait([self = shared_from_this(), frame](ErrorCodeB ec) {
            if (ec || self->mFinished || frame != self->mFramesStarted || !self->mWriting) return;
            self->finish(errorStatus(
                ErrorCode::kIoError,
                fmt::format("{}: no {} KiB written in {} ms", kWriteStallText,
                            kWriteChunkBytes / 1024, self->mConfig.writeStallTimeoutMs)));
        });
        mWs.async_write_some(fin, asio::buffer(front.bytes.data() + front.written, n),
                             [self = shared_from_this(), fin](ErrorCodeB ec, size_t taken) {
                                 self->frameWritten(ec, taken, fin);
                             });
    }

    void frameWritten(ErrorCodeB ec, size_t taken, bool fin) {
        ++mFramesStarted;  // a stall timer already due finds a newer frame and does nothing
        mStallTimer.cancel();
        if (!ec && !fin && !mFinished && !mOutbox.empty()) {
            mOutbox.front().written += taken;
            return writeFrame();
        }
        written(ec);
    }

    void written(ErrorCodeB ec) {
        mWriting = false;
        if (mOutbox.empty()) return;  // finished meanwhile
        Outgoing out = std::move(mOutbox.front());
        mOutbox.pop_front();
        mQueued -= out.bytes.size();
        Status s = ec ? fromBoost(ec, "write") : Status::ok();
        if (s.isOk() && ec) s = errorStatus(ErrorCode::kIoError, "write: connection closed");
        if (out.done) out.done(s);
        if (ec) return finish(s);
        pump();
    }

    void readMore() {
        if (!mStarted || mReading || mFinished || !mWantRead || mClosing) return;
        if (mDelayed.size() >= kMaxDelayedMessages) return;
        mReading = true;
        mWs.async_read(mReadBuffer, [self = shared_from_this()](ErrorCodeB ec, size_t) {
            self->mReading = false;
            self->gotMessage(ec);
        });
    }

    void gotMessage(ErrorCodeB ec) {
        if (ec) {
            if (ec == websocket::error::message_too_big)
                return finish(errorStatus(
                    ErrorCode::kOutOfRange,
                    fmt::format("message larger than {} bytes", mConfig.maxMessageBytes)));
            // An unmasked or reserved-bit frame, a bad opcode, a fragmented control frame
            // (RFC 6455 section 5): Beast has sent close 1002 and torn the connection down.
            if (ec == websocket::condition::protocol_violation)
                return finish(errorStatus(ErrorCode::kCorruptData,
                                          "WebSocket protocol violation: " + ec.message()));
            return finish(fromBoost(ec, "read"));
        }
        mAwaitingFirst = false;
        auto data = mReadBuffer.cdata();
        const auto* p = static_cast<const uint8_t*>(data.data());
        std::vector<uint8_t> m(p, p + data.size());
        mReadBuffer.consume(mReadBuffer.size());
        const bool binary = mWs.got_binary();
        if (!mConfig.link.active()) {
            deliver(std::move(m), binary);
        } else {
            Clock::time_point release = mInShaper.release(m.size(), Clock::now());
            mDelayed.push_back({std::move(m), binary, release});
            if (mDelayed.size() == 1) armRecvTimer();
        }
        readMore();
    }

    void armRecvTimer() {
        mRecvTimer.expires_at(mDelayed.front().release);
        mRecvTimer.async_wait([self = shared_from_this()](ErrorCodeB ec) {
            if (ec || self->mFinished) return;
            while (!self->mDelayed.empty() && self->mDelayed.front().release <= Clock::now()) {
                Delayed d = std::move(self->mDelayed.front());
                self->mDelayed.pop_front();
                self->deliver(std::move(d.bytes), d.binary);
                if (self->mFinished) return;
            }
            if (!self->mDelayed.empty()) self->armRecvTimer();
            self->readMore();
        });
    }

    void deliver(std::vector<uint8_t>&& m, bool binary) {
        if (mEvents.onMessage) mEvents.onMessage(std::move(m), binary);
    }

    void finish(const Status& why) {
        if (mFinished) return;
        mFinished = true;
        mSendTimer.cancel();
        mRecvTimer.cancel();
        mStallTimer.cancel();
        ErrorCodeB ignored;
        beast::get_lowest_layer(mWs).socket().close(ignored);
        std::deque<Outgoing> left = std::move(mOutbox);
        mOutbox.clear();
        for (Outgoing& o : left) {
            mQueued -= o.bytes.size();
            if (o.done) o.done(errorStatus(ErrorCode::kIoError, "connection closed"));
        }
        ConnectionEvents events = std::move(mEvents);
        mEvents = {};
        if (events.onClosed) events.onClosed(why);
    }

    struct Delayed {
        std::vector<uint8_t> bytes;
        bool binary;
        Clock::time_point release;
    };

    // The transport's; it outlives the connection (a pending handler that holds the last
    // reference is destroyed with the io_context, which then destroys the socket).
    asio::io_context& mIo;
    websocket::stream<beast::tcp_stream> mWs;
    ConnectionConfig mConfig;
    std::string mPeerAddress, mPeerGroup;  // tcpConnected
    ConnectionEvents mEvents;
    asio::steady_timer mSendTimer, mRecvTimer, mStallTimer;
    uint64_t mFramesStarted = 0;  // tells a stall timer whether its frame is still being written
    LinkShaper mOutShaper, mInShaper;
    beast::flat_buffer mReadBuffer;
    std::deque<Outgoing> mOutbox;
    struct HandedOver {
        std::vector<uint8_t> bytes;
        std::function<void(const Status&)> done;
    };
    std::mutex mHandedOverMutex;
    std::deque<HandedOver> mHandedOver;  // sent, not yet on the outbox (send, takeHandedOver)
    std::deque<Delayed> mDelayed;
    std::atomic<size_t> mQueued{0};
    bool mStarted = false, mWriting = false, mReading = false, mWantRead = true;
    bool mCloseWhenDrained = false, mClosing = false, mFinished = false;
    bool mOnListener = false, mAwaitingFirst = false;  // pending
    std::function<void()> mBecamePending;
};

}  // namespace

Status checkBindAddress(const std::string& bind) {
    return parseIpAddress(bind, "bind address").status();
}

Status checkSourceAddress(const std::string& source) {
    if (source.empty()) return Status::ok();
    auto address = parseSourceAddress(source);
    if (!address) return address.status();
    asio::io_context io;
    tcp::socket probe(io);
    ErrorCodeB ec;
    probe.open(address->is_v4() ? tcp::v4() : tcp::v6(), ec);
    if (!ec) probe.bind(tcp::endpoint(*address, 0), ec);
    if (ec)
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("source address {} cannot be bound: {}", source, ec.message()));
    return Status::ok();
}

std::string addressGroup(std::string_view address) {
    ErrorCodeB ec;
    const asio::ip::address parsed = asio::ip::make_address(address, ec);
    if (ec || !parsed.is_v6()) return std::string(address);
    asio::ip::address_v6::bytes_type bytes = parsed.to_v6().to_bytes();
    std::fill(bytes.begin() + 8, bytes.end(), uint8_t(0));
    return asio::ip::make_address_v6(bytes).to_string() + "/64";
}

Status checkWriteStallTimeout(double ms) {
    if (!(ms >= 100.0 && ms <= 3600e3))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("write timeout {} s outside 0.1..3600", ms / 1000.0));
    return Status::ok();
}

bool isWriteStall(const Status& why) {
    return !why.isOk() && why.message().starts_with(kWriteStallText);
}

Status checkMaxPending(int connections) {
    if (connections < 1 || connections > 65536)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("max pending connections {} outside 1..65536", connections));
    return Status::ok();
}

// The index in `pending` (oldest first) of the oldest connection of the peer address group
// (addressGroup) that has the most there; of groups with as many, the one whose oldest is oldest.
size_t oldestOfBusiestGroup(const std::vector<std::shared_ptr<WsConnection>>& pending) {
    std::unordered_map<std::string_view, std::pair<size_t, size_t>> byGroup;  // count, oldest
    byGroup.reserve(pending.size());
    for (size_t i = 0; i < pending.size(); ++i)
        ++byGroup.try_emplace(pending[i]->group(), 0, i).first->second.first;
    size_t oldest = 0, most = 0;
    for (const auto& [group, entry] : byGroup)
        if (entry.first > most || (entry.first == most && entry.second < oldest))
            std::tie(most, oldest) = entry;
    return oldest;
}

struct Transport::Impl {
    std::unique_ptr<asio::io_context> io = std::make_unique<asio::io_context>(1);
    asio::executor_work_guard<asio::io_context::executor_type> work{io->get_executor()};
    std::thread thread;
    std::unique_ptr<tcp::acceptor> acceptor;
    asio::steady_timer acceptRetry{*io};
    std::chrono::milliseconds acceptBackoff{0};  // the wait before the next accept; 0 after success
    std::mutex mutex;  // guards stopped
    bool stopped = false;
    std::vector<std::weak_ptr<WsConnection>> connections;  // I/O thread only, oldest first
    std::atomic<int64_t> acceptFailures{0}, pendingDropped{0};

    void track(const std::shared_ptr<WsConnection>& c) {
        std::erase_if(connections, [](const auto& w) { return w.expired(); });
        connections.push_back(c);
    }

    // Drops pending connections (WsConnection::pending) while more than maxPending are open
    // (ConnectionConfig::maxPendingConnections), each time the oldest of the peer address group
    // (addressGroup) that holds the most. A client that is not flooding completes its handshake
    // and first message within a round trip or two, and a close within one, so the oldest
    // pending connections are a flood's: peers that say nothing, or that are refused and never
    // read the refusal. Taken from the busiest group, a flood from one address (or IPv6 /64)
    // drops its own connections, not other clients in their handshakes.
    void limitPending(int maxPending) {
        std::vector<std::shared_ptr<WsConnection>> pending;  // oldest first
        for (const auto& w : connections)
            if (auto c = w.lock(); c && c->pending()) pending.push_back(std::move(c));
        while (pending.size() > size_t(maxPending)) {
            auto victim = pending.begin() + std::ptrdiff_t(oldestOfBusiestGroup(pending));
            (*victim)->drop("dropped: too many pending connections");
            ++pendingDropped;
            pending.erase(victim);
        }
    }

    void acceptNext(ConnectionConfig config, AcceptHandler onAccept) {
        acceptor->async_accept([this, config, onAccept](ErrorCodeB ec, tcp::socket socket) {
            if (ec == asio::error::operation_aborted || !acceptor || !acceptor->is_open()) return;
            if (ec) return acceptLater(config, onAccept);
            acceptBackoff = {};
            auto c = std::make_shared<WsConnection>(*io, std::move(socket), config);
            track(c);
            c->setTimeouts(true);
            const int maxPending = config.maxPendingConnections;
            c->acceptRequest(onAccept, [this, maxPending] { limitPending(maxPending); });
            limitPending(maxPending);
            acceptNext(config, onAccept);
        });
    }

    // After a failed accept (out of file descriptors or memory): the connection stays in the
    // backlog, so accepting again at once fails again at once and spins the I/O thread. Waits
    // 5 ms, doubled while accepts keep failing, up to 1 s.
    void acceptLater(ConnectionConfig config, AcceptHandler onAccept) {
        using std::chrono::milliseconds;
        ++acceptFailures;
        acceptBackoff = std::clamp(acceptBackoff * 2, milliseconds(5), milliseconds(1000));
        acceptRetry.expires_after(acceptBackoff);
        acceptRetry.async_wait([this, config, onAccept](ErrorCodeB ec) {
            if (ec || !acceptor || !acceptor->is_open()) return;
            acceptNext(config, onAccept);
        });
    }
};

Transport::Transport(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
Transport::~Transport() {
    stop();
}

Result<std::unique_ptr<Transport>> Transport::create() {
    auto impl = std::make_unique<Impl>();
    Impl* p = impl.get();
    impl->thread = std::thread([p] { p->io->run(); });
    return std::unique_ptr<Transport>(new Transport(std::move(impl)));
}

Result<int> Transport::listen(const std::string& bind, int port, const ConnectionConfig& config,
                              AcceptHandler onAccept) {
    if (port < 0 || port > 65535)
        return errorStatus(ErrorCode::kInvalidArgument, fmt::format("port {} out of range", port));
    auto parsed = parseIpAddress(bind, "bind address");
    if (!parsed) return parsed.status();
    if (Status s = checkMaxPending(config.maxPendingConnections); !s.isOk()) return s;
    const asio::ip::address address = *parsed;
    std::promise<Result<int>> bound;
    asio::post(*mImpl->io, [&] {
        Impl& m = *mImpl;
        tcp::endpoint endpoint(address, uint16_t(port));
        auto acceptor = std::make_unique<tcp::acceptor>(*m.io);
        ErrorCodeB e;
        acceptor->open(endpoint.protocol(), e);
        if (!e) acceptor->set_option(asio::socket_base::reuse_address(true), e);
        if (!e) acceptor->bind(endpoint, e);
        if (!e) acceptor->listen(asio::socket_base::max_listen_connections, e);
        if (e) {
            bound.set_value(
                errorStatus(ErrorCode::kIoError,
                            fmt::format("cannot listen on {}:{}: {}", bind, port, e.message())));
            return;
        }
        int actual = acceptor->local_endpoint().port();
        m.acceptor = std::move(acceptor);
        m.acceptNext(config, onAccept);
        bound.set_value(actual);
    });
    return bound.get_future().get();
}

void Transport::stopListening() {
    std::promise<void> done;
    asio::post(*mImpl->io, [&] {
        if (mImpl->acceptor) {
            ErrorCodeB ignored;
            mImpl->acceptor->close(ignored);
        }
        mImpl->acceptRetry.cancel();
        done.set_value();
    });
    done.get_future().wait();
}

Transport::ListenerStats Transport::listenerStats() const {
    return {mImpl->acceptFailures.load(), mImpl->pendingDropped.load()};
}

Result<std::shared_ptr<Connection>> Transport::connect(const std::string& host, int port,
                                                       const std::string& path,
                                                       const ConnectionConfig& config,
                                                       ConnectionEvents events) {
    std::optional<asio::ip::address> source;
    if (!config.sourceAddress.empty()) {
        auto parsed = parseSourceAddress(config.sourceAddress);
        if (!parsed) return parsed.status();
        source = *parsed;
    }
    // The outcome, set once on the I/O thread; waited for with the caller's stop token.
    struct Outcome {
        std::mutex mutex;
        std::condition_variable_any settled;
        std::optional<Result<std::shared_ptr<Connection>>> result;
    };
    auto outcome = std::make_shared<Outcome>();
    auto settle = [outcome](Result<std::shared_ptr<Connection>> r) {
        std::lock_guard lock(outcome->mutex);
        outcome->result.emplace(std::move(r));
        outcome->settled.notify_all();
    };
    auto resolver = std::make_shared<tcp::resolver>(*mImpl->io);
    auto c = std::make_shared<WsConnection>(*mImpl->io, tcp::socket(*mImpl->io), config);
    auto fail = [settle, host, port](const std::string& step, ErrorCodeB ec) {
        settle(errorStatus(ErrorCode::kIoError, fmt::format("{} ws://{}: {}", step,
                                                            authority(host, port), ec.message())));
    };
    const auto timeout =
        std::chrono::milliseconds(int64_t(std::max(1.0, config.handshakeTimeoutMs)));
    auto ev = std::make_shared<ConnectionEvents>(std::move(events));
    auto handshake = [=](ErrorCodeB ec, const tcp::endpoint& peer) {
        if (ec) return fail("cannot connect to", ec);
        c->tcpConnected(peer);
        c->setTimeouts(false);
        c->ws().async_handshake(authority(host, port), path, [=](ErrorCodeB hec) {
            if (hec) return fail("WebSocket handshake with", hec);
            c->start(std::move(*ev));
            settle(std::shared_ptr<Connection>(c));
        });
    };
    asio::post(*mImpl->io, [=, this] {
        mImpl->track(c);
        resolver->async_resolve(
            host, std::to_string(port), [=](ErrorCodeB ec, tcp::resolver::results_type r) {
                if (ec) return fail("cannot resolve", ec);
                auto& stream = beast::get_lowest_layer(c->ws());
                stream.expires_after(timeout);
                if (!source) return stream.async_connect(r, handshake);
                // Bound first, then connected to one endpoint: the range's connect reopens the
                // socket for each endpoint it tries, which would drop the bind.
                const auto family = source->is_v4() ? tcp::v4() : tcp::v6();
                auto to = std::find_if(r.begin(), r.end(), [&](const auto& entry) {
                    return entry.endpoint().protocol() == family;
                });
                ErrorCodeB bec =
                    to == r.end() ? asio::error::address_family_not_supported : ErrorCodeB{};
                if (!bec) stream.socket().open(family, bec);
                if (!bec) stream.socket().bind(tcp::endpoint(*source, 0), bec);
                if (bec)
                    return fail(fmt::format("cannot connect from {} to", source->to_string()), bec);
                const tcp::endpoint peer = to->endpoint();
                stream.async_connect(peer, [=](ErrorCodeB cec) { handshake(cec, peer); });
            });
    });
    // The handshake timeout bounds each step; the extra second covers name resolution.
    std::unique_lock lock(outcome->mutex);
    if (!outcome->settled.wait_for(lock, config.cancel, timeout * 3 + std::chrono::seconds(1),
                                   [&] { return outcome->result.has_value(); })) {
        lock.unlock();
        c->abort();
        return errorStatus(ErrorCode::kIoError,
                           fmt::format("connecting to ws://{} {}", authority(host, port),
                                       config.cancel.stop_requested() ? "cancelled" : "timed out"));
    }
    return std::move(*outcome->result);
}

void Transport::stop() {
    {
        std::lock_guard lock(mImpl->mutex);
        if (mImpl->stopped) return;
        mImpl->stopped = true;
    }
    std::promise<void> dropped;
    asio::post(*mImpl->io, [&] {
        if (mImpl->acceptor) {
            ErrorCodeB ignored;
            mImpl->acceptor->close(ignored);
        }
        mImpl->acceptRetry.cancel();
        for (auto& w : mImpl->connections)
            if (auto c = w.lock()) c->drop("transport stopped");
        mImpl->connections.clear();
        dropped.set_value();
    });
    dropped.get_future().wait();
    mImpl->work.reset();
    mImpl->io->stop();
    if (mImpl->thread.joinable()) mImpl->thread.join();
    mImpl->acceptor.reset();
}

Result<WsUrl> parseWsUrl(const std::string& url) {
    auto bad = [&](const std::string& problem) {
        return errorStatus(ErrorCode::kInvalidArgument, fmt::format("'{}' {}", url, problem));
    };
    const std::string scheme = "ws://";
    if (url.rfind(scheme, 0) != 0) return bad("is not a ws://HOST:PORT address");
    std::string rest = url.substr(scheme.size());
    WsUrl out;
    size_t slash = rest.find('/');
    if (slash != std::string::npos) out.path = rest.substr(slash), rest = rest.substr(0, slash);
    // The authority (RFC 3986 section 3.2.2): HOST[:PORT], or [IPV6][:PORT].
    size_t hostEnd = rest.find(':');
    if (rest.rfind('[', 0) == 0) {
        const size_t close = rest.find(']');
        if (close == std::string::npos) return bad("opens an IPv6 address with '[' but no ']'");
        out.host = rest.substr(1, close - 1);
        hostEnd = close + 1;
        if (hostEnd < rest.size() && rest[hostEnd] != ':')
            return bad("has more after ']' than ':PORT'");
    } else {
        if (hostEnd != std::string::npos && rest.find(':', hostEnd + 1) != std::string::npos)
            return bad("names an IPv6 address without brackets (write ws://[::1]:8080/)");
        out.host = rest.substr(0, hostEnd);
    }
    if (hostEnd < rest.size()) {
        const std::string port = rest.substr(hostEnd + 1);
        if (port.empty() || port.size() > 5 ||
            port.find_first_not_of("0123456789") != std::string::npos || std::stoi(port) < 1 ||
            std::stoi(port) > 65535)
            return bad(fmt::format("has port '{}', not 1..65535", port));
        out.port = std::stoi(port);
    }
    if (out.host.empty()) return bad("has no host");
    return out;
}

std::string authority(const std::string& host, int port) {
    if (host.find(':') != std::string::npos) return fmt::format("[{}]:{}", host, port);
    return fmt::format("{}:{}", host, port);
}

}  // namespace plx::remote
