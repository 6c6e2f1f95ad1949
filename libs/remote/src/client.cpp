// The client's I/O thread (connect, handshake, send poses and pings, receive sets; reconnect with
// exponential backoff) and its decode thread (the newest received set, decoded into the buffers
// of one the display loop has let go).

#include <plx/remote/client.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <stop_token>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <oneapi/tbb/task_arena.h>

#include <plx/remote/transport.h>

#include "one_unwritten.h"

namespace plx::remote {

using Clock = std::chrono::steady_clock;

uint64_t clientNowUs() {
    return uint64_t(
        std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch())
            .count());
}

namespace {

// A pose is not sent while this many bytes wait on the socket: a stalled link gets the newest
// pose later rather than a queue of stale ones.
constexpr size_t kMaxQueuedPoseBytes = 4096;

// Pings whose Pong still counts: a round trip longer than the ping interval is normal.
constexpr uint32_t kPingsRemembered = 64;

// What one connection's callbacks report to the I/O thread.
struct Link {
    bool closed = false;
    Clock::time_point lastHeard = Clock::now();  // the server's latest message
    std::optional<ServerHello> hello;
    Status error;  // an Error message from the server, or a message the client refused
    uint32_t pingNonce = 0;
    std::array<uint64_t, kPingsRemembered> pingSentUs{};  // by nonce % kPingsRemembered
    OneUnwritten pings, pongs;  // a server that stops reading gets no queue of them
    std::optional<uint32_t> lastSequence;  // of the last set decoded (decode thread only)
};

}  // namespace

struct Client::Impl {
    ClientConfig config;
    std::unique_ptr<Transport> transport;
    std::thread thread;

    mutable std::mutex mutex;
    mutable std::condition_variable changed;
    bool stopping = false;
    std::stop_source stopConnecting;  // requested with stopping: a connect under way ends
    std::optional<PoseMessage> pose;
    uint64_t poseVersion = 0, sentVersion = 0;
    std::shared_ptr<const ReceivedSet> newest;
    Status fatal;
    ClientStats stats;
    std::shared_ptr<Connection> conn;
    std::shared_ptr<Link> current;  // conn's link

    // A set waiting for the decode thread, with the connection it came on.
    struct PendingSet {
        std::vector<uint8_t> bytes;
        std::shared_ptr<Link> link;
        uint64_t arrivalUs = 0;
        DecodeLimits limits;  // the link's, as its ServerHello announced
    };
    std::optional<PendingSet> pending;  // the newest undecoded set; a newer one replaces it
    std::thread decoder;
    // Sets the display loop held last, kept for their buffers; only the decode thread reaches
    // them. Two: a display frame that began before a set was published still reads the set it
    // replaced when the next decode starts, and a new set is fresh memory to fault in and clear
    // (50 MB at 1248-pixel cube4 faces; with one spare that took a fifth of the decode).
    static constexpr size_t kSpareSets = 2;
    std::vector<std::shared_ptr<ReceivedSet>> spares;  // oldest first

    // Runs on the transport's I/O thread, which must stay free for pings and pongs: a set
    // (tens of milliseconds to decode at 1280x720) goes to the decode thread, so a pong is read
    // when it arrives and the RTT, and the server's prediction lead with it, is the network's.
    void onMessage(const std::shared_ptr<Link>& link, std::vector<uint8_t>&& bytes, bool binary) {
        if (!binary) {
            refuse(link,
                   errorStatus(ErrorCode::kCorruptData, "text message (binary messages only)"));
            return;
        }
        if (!mayBeSentBy(bytes, Peer::kServer)) {
            refuse(link, errorStatus(ErrorCode::kCorruptData,
                                     fmt::format("unexpected {} from the server",
                                                 messageTypeName(MessageType(bytes[0])))));
            return;
        }
        const uint64_t arrival = clientNowUs();
        if (!bytes.empty() && bytes[0] == uint8_t(MessageType::kReferenceSet)) {
            std::unique_lock lock(mutex);
            if (!link->hello || !link->hello->accepted) {
                lock.unlock();
                refuse(link, errorStatus(ErrorCode::kCorruptData,
                                         "reference set before the server accepted the session"));
                return;
            }
            link->lastHeard = Clock::now();
            if (pending) ++stats.referencesDropped;
            pending = PendingSet{std::move(bytes), link, arrival,
                                 announcedLimits(*link->hello, config.limits)};
            changed.notify_all();
            return;
        }
        auto m = decodeMessage(bytes, config.limits);
        if (!m) {
            refuse(link, m.status());
            return;
        }
        std::unique_lock lock(mutex);
        link->lastHeard = Clock::now();
        if (auto* hello = std::get_if<ServerHello>(&*m)) {
            if (link->hello) {
                lock.unlock();
                refuse(link, errorStatus(ErrorCode::kCorruptData,
                                         "server hello after the session began"));
                return;
            }
            link->hello = *hello;
        } else if (auto* ping = std::get_if<Ping>(&*m)) {
            if (conn && link == current)
                link->pongs.send(*conn, Pong{ping->timestampUs, ping->nonce});
        } else if (auto* pong = std::get_if<Pong>(&*m)) {
            // Only a Pong that echoes one of the last pings sent, nonce and timestamp, is a
            // round trip; any other would report a made-up one.
            const bool echoesAPing =
                link->pingNonce - pong->nonce < kPingsRemembered && pong->timestampUs != 0 &&
                link->pingSentUs[pong->nonce % kPingsRemembered] == pong->timestampUs;
            if (echoesAPing) {
                double rtt = double(arrival - pong->timestampUs) * 1e-3;
                stats.rttMs = stats.rttMs < 0.0 ? rtt : 0.75 * stats.rttMs + 0.25 * rtt;
            }
        } else if (auto* err = std::get_if<ErrorMessage>(&*m)) {
            // The text is the peer's bytes: shown escaped (docs/remote-protocol.md).
            link->error =
                errorStatus(ErrorCode::kIoError, "server: " + printable(err->text, kMaxTextBytes));
        }
        changed.notify_all();
    }

    // A server that breaks the protocol is told so; the session ends and is retried. Only the
    // connection the bad message came on is closed (a set decoded late may be from an old one).
    // The caller learns why: the session's error before a ServerHello, lastError after one.
    void refuse(const std::shared_ptr<Link>& link, const Status& why) {
        auto e = encodeMessage(
            ErrorMessage{ErrorKind::kProtocol, why.message().substr(0, kMaxTextBytes)});
        std::lock_guard lock(mutex);
        if (link->error.isOk())
            link->error = errorStatus(why.code(), "bad message from the server: " + why.message());
        stats.lastError = link->error.message();
        changed.notify_all();
        if (!conn || link != current) return;
        if (e) conn->send(std::move(e).value());
        conn->close();
    }

    // A spare no display frame reads any more, or a new set. A count of 1 means no frame holds
    // it; the count fell by a release decrement, so the fence orders the reuse after the last
    // reader's reads.
    std::shared_ptr<ReceivedSet> takeSpare() {
        for (auto it = spares.begin(); it != spares.end(); ++it) {
            if (it->use_count() != 1) continue;
            std::shared_ptr<ReceivedSet> r = std::move(*it);
            spares.erase(it);
            std::atomic_thread_fence(std::memory_order_acquire);
            return r;
        }
        return std::make_shared<ReceivedSet>();
    }

    void keepSpare(std::shared_ptr<ReceivedSet> r) {
        if (!r) return;
        spares.push_back(std::move(r));
        if (spares.size() > kSpareSets) spares.erase(spares.begin());
    }

    // A set's sequence increases within a session (docs/remote-protocol.md), and the pose it
    // answers was sent before it arrived: otherwise the client's reference age and its stats
    // would report what never happened.
    static Status checkSetOrder(const ReferenceSetMessage& m, const PendingSet& job) {
        const std::optional<uint32_t> last = job.link->lastSequence;
        if (last && m.sequence <= *last)
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("reference set {} after set {}", m.sequence, *last));
        if (m.requestTimestampUs > job.arrivalUs)
            return errorStatus(ErrorCode::kCorruptData,
                               "reference set answers a pose timestamped after its arrival");
        job.link->lastSequence = m.sequence;
        return Status::ok();
    }

    // The decode thread: the newest pending set, decoded into the buffers of a set the display
    // loop no longer holds, published as the newest.
    void decodeLoop() {
        // One slot: the set's views decode one after the other on this thread. Spread over the
        // TBB workers (the codec's per-view tasks) they held workers that the display loop's
        // warp then waited for: at 1280x720 with the server on the same two cores the loop ran
        // at 41 frames/s against 47.5 serially, for the same sets per second
        // (docs/remote-results.md).
        tbb::task_arena serial(1);
        std::unique_lock lock(mutex);
        while (true) {
            changed.wait(lock, [&] { return stopping || pending; });
            if (stopping) return;
            PendingSet job = std::move(*pending);
            pending.reset();
            lock.unlock();
            std::shared_ptr<ReceivedSet> r = takeSpare();
            Clock::time_point decodeStart = Clock::now();
            ReferenceSetMessage m;
            m.set = std::move(r->set);
            Status s;
            serial.execute([&] { s = decodeReferenceSetMessage(job.bytes, job.limits, &m); });
            const double ms =
                std::chrono::duration<double, std::milli>(Clock::now() - decodeStart).count();
            r->set = std::move(m.set);
            if (s.isOk()) s = checkSetOrder(m, job);
            if (!s.isOk()) {
                refuse(job.link, s);
                keepSpare(std::move(r));  // its buffers serve the next set
                lock.lock();
                continue;
            }
            r->sequence = m.sequence;
            r->requestTimestampUs = m.requestTimestampUs;
            r->arrivalUs = job.arrivalUs;
            r->bytes = job.bytes.size();
            lock.lock();
            // The newest wins; the one it replaces is kept for its buffers (outside the lock: a
            // spare dropped there frees tens of megabytes).
            auto replaced =
                std::const_pointer_cast<ReceivedSet>(std::exchange(newest, std::move(r)));
            ++stats.referencesReceived;
            stats.bytesReceived += int64_t(newest->bytes);
            stats.decodeMsMean += (ms - stats.decodeMsMean) / double(stats.referencesReceived);
            changed.notify_all();
            lock.unlock();
            keepSpare(std::move(replaced));
            lock.lock();
        }
    }

    // Waits for `until` or for stop; false when stopping.
    bool sleepUntil(Clock::time_point until) {
        std::unique_lock lock(mutex);
        changed.wait_until(lock, until, [&] { return stopping; });
        return !stopping;
    }

    void run() {
        double backoffMs = config.backoffMinMs;
        while (true) {
            {
                std::lock_guard lock(mutex);
                if (stopping) break;
            }
            Status ended = session();
            {
                std::lock_guard lock(mutex);
                stats.connected = false;
                conn.reset();
                current.reset();
                if (!ended.isOk()) stats.lastError = ended.message();
                if (stopping || !fatal.isOk()) break;
                if (stats.connects > 0 && ended.isOk()) backoffMs = config.backoffMinMs;
            }
            auto wait = std::chrono::duration_cast<Clock::duration>(
                std::chrono::duration<double, std::milli>(backoffMs));
            if (!sleepUntil(Clock::now() + wait)) break;
            backoffMs = std::min(backoffMs * 2.0, config.backoffMaxMs);
        }
    }

    // One connection: handshake, then poses and pings until it closes. ok when it got as far
    // as an accepted handshake and no Error ended it (the backoff restarts), an error otherwise.
    Status session() {
        auto link = std::make_shared<Link>();
        ConnectionEvents ev;
        ev.onMessage = [this, link](std::vector<uint8_t>&& m, bool binary) {
            onMessage(link, std::move(m), binary);
        };
        ev.onClosed = [this, link](const Status& why) {
            std::lock_guard lock(mutex);
            link->closed = true;
            // A close the transport saw fail (a frame too large, a WebSocket protocol error) is
            // why the session ended; the caller's "no reference set" names it.
            if (!why.isOk() && link->error.isOk())
                link->error = errorStatus(why.code(), "connection: " + why.message());
            changed.notify_all();
        };
        ConnectionConfig cc;
        cc.maxMessageBytes = kMaxReferenceSetMessageBytes;
        cc.handshakeTimeoutMs = config.connectTimeoutMs;
        cc.sourceAddress = config.sourceAddress;
        cc.cancel = stopConnecting.get_token();
        auto c = transport->connect(config.host, config.port, config.path, cc, std::move(ev));
        if (!c) return c.status();
        ClientHello hello;
        hello.layout = config.layout;
        hello.faceSize = config.faceSize;
        hello.token = config.token;
        {
            std::lock_guard lock(mutex);
            conn = *c;
            current = link;
        }
        if (auto bytes = encodeMessage(hello)) (*c)->send(std::move(bytes).value());
        ServerHello answer;
        {
            std::unique_lock lock(mutex);
            changed.wait_for(
                lock, std::chrono::duration<double, std::milli>(config.connectTimeoutMs),
                [&] { return stopping || link->closed || link->hello || !link->error.isOk(); });
            if (stopping) return Status::ok();
            if (!link->hello) {
                // A message refused before the hello was answered with an Error, which a close
                // sends first and an abort would drop.
                if (!link->error.isOk()) {
                    (*c)->close();
                    return link->error;
                }
                (*c)->abort();
                return errorStatus(ErrorCode::kIoError, "no ServerHello");
            }
            answer = *link->hello;
            if (!answer.accepted) {
                fatal = errorStatus(ErrorCode::kUnsupported, "server refused: " + answer.reason);
                changed.notify_all();
                (*c)->close();
                return fatal;
            }
            ++stats.connects;
            stats.connected = true;
            stats.faceSize = answer.faceSize;
            stats.poseRateHz = answer.poseRateHz;
        }
        const auto poseInterval = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(1.0 / std::max(1, answer.poseRateHz)));
        const auto pingInterval = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double, std::milli>(config.pingIntervalMs));
        Clock::time_point nextPose = Clock::now(), nextPing = Clock::now();
        std::unique_lock lock(mutex);
        // An Error from the server ends the session whether or not the server closes.
        auto ended = [&] { return stopping || link->closed || !link->error.isOk(); };
        const auto silence = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double, std::milli>(config.silenceTimeoutMs));
        while (!ended()) {
            changed.wait_until(lock, std::min({nextPose, nextPing, link->lastHeard + silence}),
                               ended);
            if (ended()) break;
            Clock::time_point now = Clock::now();
            if (now - link->lastHeard >= silence) {
                link->error = errorStatus(ErrorCode::kIoError,
                                          fmt::format("no message from the server for {:.1f} s",
                                                      config.silenceTimeoutMs / 1000.0));
                break;
            }
            if (now >= nextPose) {
                nextPose = std::max(nextPose + poseInterval, now);
                // Each pose once (the newest), and never onto a backed-up socket.
                if (pose && sentVersion != poseVersion &&
                    conn->queuedBytes() < kMaxQueuedPoseBytes) {
                    if (auto b = encodeMessage(*pose)) {
                        conn->send(std::move(b).value());
                        sentVersion = poseVersion;
                        ++stats.posesSent;
                    }
                }
            }
            if (now >= nextPing) {
                nextPing = now + pingInterval;
                const uint64_t sentUs = clientNowUs();
                link->pingSentUs[++link->pingNonce % kPingsRemembered] = sentUs;
                link->pings.send(*conn, Ping{sentUs, link->pingNonce});
            }
        }
        if (stopping && !link->closed) {
            if (auto b = encodeMessage(Bye{ByeReason::kNormal, "client done"}))
                conn->send(std::move(b).value());
            conn->close();
            changed.wait_for(lock, std::chrono::milliseconds(500), [&] { return link->closed; });
        }
        if (!stopping && !link->error.isOk()) {
            if (!link->closed) conn->close();
            return link->error;
        }
        return Status::ok();
    }
};

Client::Client(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
Client::~Client() {
    stop();
}

Result<std::unique_ptr<Client>> Client::create(const ClientConfig& config) {
    if (config.faceSize < kMinFaceSize || config.faceSize > kMaxFaceSize)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("face size {} outside {}..{}", config.faceSize, kMinFaceSize,
                                       kMaxFaceSize));
    if (config.token.size() > size_t(kMaxTokenBytes))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("token longer than {} bytes", kMaxTokenBytes));
    if (config.port < 1 || config.port > 65535)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("port {} outside 1..65535", config.port));
    if (!(config.backoffMinMs > 0.0 && config.backoffMaxMs >= config.backoffMinMs &&
          config.backoffMaxMs <= 60000.0 && config.pingIntervalMs >= 10.0 &&
          config.connectTimeoutMs > 0.0 && config.silenceTimeoutMs > 2.0 * config.pingIntervalMs &&
          config.silenceTimeoutMs <= 3600e3))
        return errorStatus(ErrorCode::kInvalidArgument, "client timing options out of range");
    PLX_RETURN_IF_ERROR(checkSourceAddress(config.sourceAddress));
    auto impl = std::make_unique<Impl>();
    impl->config = config;
    auto transport = Transport::create();
    if (!transport) return transport.status();
    impl->transport = std::move(transport).value();
    Impl* p = impl.get();
    impl->thread = std::thread([p] { p->run(); });
    impl->decoder = std::thread([p] { p->decodeLoop(); });
    return std::unique_ptr<Client>(new Client(std::move(impl)));
}

void Client::setPose(const PoseMessage& pose) {
    std::lock_guard lock(mImpl->mutex);
    mImpl->pose = pose;
    ++mImpl->poseVersion;
}

std::shared_ptr<const ReceivedSet> Client::newest() const {
    std::lock_guard lock(mImpl->mutex);
    return mImpl->newest;
}

bool Client::waitForFirst(double timeoutMs) const {
    std::unique_lock lock(mImpl->mutex);
    mImpl->changed.wait_for(lock, std::chrono::duration<double, std::milli>(timeoutMs), [&] {
        return mImpl->newest != nullptr || !mImpl->fatal.isOk() || mImpl->stopping;
    });
    return mImpl->newest != nullptr;
}

Status Client::fatal() const {
    std::lock_guard lock(mImpl->mutex);
    return mImpl->fatal;
}

ClientStats Client::stats() const {
    std::lock_guard lock(mImpl->mutex);
    ClientStats s = mImpl->stats;
    s.queuedBytes = mImpl->conn ? mImpl->conn->queuedBytes() : 0;
    return s;
}

void Client::stop() {
    {
        std::lock_guard lock(mImpl->mutex);
        if (mImpl->stopping && !mImpl->thread.joinable()) return;
        mImpl->stopping = true;
        mImpl->changed.notify_all();
    }
    mImpl->stopConnecting.request_stop();
    if (mImpl->thread.joinable()) mImpl->thread.join();
    if (mImpl->decoder.joinable()) mImpl->decoder.join();
    mImpl->transport->stop();
}

}  // namespace plx::remote
