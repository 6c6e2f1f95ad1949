// Server and client in one process over loopback (127.0.0.1, free ports): the handshake, sets
// that arrive and warp, abuse from raw WebSocket peers, a stalled reader, many clients, abrupt
// disconnects, a restart. Every wait is bounded; nothing here measures speed.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <plx/raster/raster.h>
#include <plx/remote/client.h>
#include <plx/remote/protocol.h>
#include <plx/remote/server.h>
#include <plx/remote/transport.h>
#include <plx/scene/generators.h>
#include <plx/warp/reference.h>

#include "test_sets.h"

namespace plx::remote {
namespace {

using namespace std::chrono_literals;

ServerConfig smallServer(int faceSize = 32) {
    ServerConfig c;
    c.port = 0;
    c.reference.faceSize = faceSize;
    c.renderThreads = 2;
    c.pingIntervalMs = 100.0;
    return c;
}

std::unique_ptr<Server> startServer(const ServerConfig& config,
                                    const std::string& spec = "office:1") {
    auto server = Server::create(*scene::generateFromSpec(spec), config);
    EXPECT_TRUE(server.isOk()) << server.status().message();
    return server ? std::move(server).value() : nullptr;
}

ClientConfig clientFor(const Server& server, int faceSize = 32) {
    ClientConfig c;
    c.port = server.port();
    c.faceSize = faceSize;
    c.pingIntervalMs = 100.0;
    c.backoffMinMs = 50.0;
    c.backoffMaxMs = 400.0;
    return c;
}

PoseMessage poseNow(const scene::Scene& scene, Vec3 velocity = Vec3(0.0f)) {
    PoseMessage p;
    p.timestampUs = clientNowUs();
    p.pose = warp::poseAt(scene.viewpoints.front());
    p.hasVelocity = true;
    p.velocity = velocity;
    return p;
}

// Waits (bounded) until pred() holds; returns whether it did.
template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds limit = 10s) {
    auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
        if (pred()) return true;
        std::this_thread::sleep_for(10ms);
    }
    return pred();
}

// A client with its first set, or null.
std::unique_ptr<Client> servedClient(const Server& server, const scene::Scene& scene) {
    auto client = std::move(Client::create(clientFor(server))).value();
    client->setPose(poseNow(scene));
    if (!client->waitForFirst(10000.0)) return nullptr;
    return client;
}

// Whether new poses keep bringing new sets (a session still served).
bool receivesMore(Client& client, const scene::Scene& scene) {
    int64_t before = client.stats().referencesReceived;
    return eventually([&] {
        client.setPose(poseNow(scene));
        return client.stats().referencesReceived > before + 2;
    });
}

// Calls sendSome() every 10 ms, at most for 30 s, until the server has written no set for
// `quiet` and holds bytes on its sockets: peers that stopped reading have backed them up.
void sendUntilBackedUp(const Server& server, const std::function<void()>& sendSome,
                       std::chrono::milliseconds quiet) {
    int64_t lastSent = -1;
    auto steadySince = std::chrono::steady_clock::now();
    const auto end = steadySince + 30s;
    while (std::chrono::steady_clock::now() < end) {
        sendSome();
        std::this_thread::sleep_for(10ms);
        ServerStats s = server.stats();
        if (s.setsSent != lastSent)
            lastSent = s.setsSent, steadySince = std::chrono::steady_clock::now();
        if (std::chrono::steady_clock::now() - steadySince > quiet && s.queuedBytes > 0) return;
    }
}

// A raw WebSocket peer: sends whatever bytes it is given and records what comes back.
class RawPeer {
public:
    // From `source` (ConnectionConfig::sourceAddress) when given.
    explicit RawPeer(int port, const std::string& source = {}) {
        mTransport = std::move(Transport::create()).value();
        ConnectionEvents ev;
        ev.onMessage = [this](std::vector<uint8_t>&& m, bool) {
            std::lock_guard lock(mMutex);
            auto decoded = decodeMessage(m);
            if (decoded && messageType(*decoded) == MessageType::kReferenceSet)
                mRawSets.push_back(m);
            if (decoded) mReceived.push_back(std::move(decoded).value());
            mChanged.notify_all();
        };
        ev.onClosed = [this](const Status& why) {
            std::lock_guard lock(mMutex);
            mClosed = true;
            mWhy = why;
            mChanged.notify_all();
        };
        ConnectionConfig cc;
        cc.maxMessageBytes = kMaxReferenceSetMessageBytes;
        cc.sourceAddress = source;
        auto c = mTransport->connect("127.0.0.1", port, "/", cc, std::move(ev));
        EXPECT_TRUE(c.isOk()) << c.status().message();
        if (c) mConn = std::move(c).value();
    }
    ~RawPeer() { mTransport->stop(); }

    Connection& conn() { return *mConn; }
    void send(const Message& m) { mConn->send(std::move(encodeMessage(m)).value()); }
    void sendBytes(std::vector<uint8_t> b) { mConn->send(std::move(b)); }
    void hello(const std::string& token = {}, uint16_t version = kProtocolVersion,
               uint8_t disparityCodecs = kAllDisparityCodecs) {
        ClientHello h;
        h.version = version;
        h.faceSize = 32;
        h.token = token;
        h.disparityCodecs = disparityCodecs;
        send(h);
    }
    // Asks for faces of faceSize, waits for the ServerHello, then stops reading: sets for its
    // poses back up on the server's socket.
    bool helloThenStopReading(int faceSize) {
        ClientHello h;
        h.faceSize = faceSize;
        send(h);
        if (!first<ServerHello>()) return false;
        mConn->setReading(false);
        return true;
    }
    // The bytes of the first reference set message received.
    std::vector<uint8_t> firstRawSet() {
        std::lock_guard lock(mMutex);
        return mRawSets.empty() ? std::vector<uint8_t>{} : mRawSets.front();
    }
    bool waitClosed(std::chrono::milliseconds limit = 10s) {
        std::unique_lock lock(mMutex);
        return mChanged.wait_for(lock, limit, [&] { return mClosed; });
    }
    // The first received message of type T (waits, bounded).
    template <class T>
    std::optional<T> first(std::chrono::milliseconds limit = 10s) {
        std::unique_lock lock(mMutex);
        std::optional<T> out;
        mChanged.wait_for(lock, limit, [&] {
            for (const Message& m : mReceived)
                if (auto* t = std::get_if<T>(&m)) return out = *t, true;
            return mClosed;
        });
        if (!out)
            for (const Message& m : mReceived)
                if (auto* t = std::get_if<T>(&m)) return *t;
        return out;
    }
    int count(MessageType type) {
        std::lock_guard lock(mMutex);
        int n = 0;
        for (const Message& m : mReceived) n += messageType(m) == type;
        return n;
    }

private:
    std::unique_ptr<Transport> mTransport;
    std::shared_ptr<Connection> mConn;
    std::mutex mMutex;
    std::condition_variable mChanged;
    std::vector<Message> mReceived;
    std::vector<std::vector<uint8_t>> mRawSets;
    bool mClosed = false;
    Status mWhy;
};

TEST(RemoteSession, ReferencesArriveAndWarp) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    auto server = startServer(smallServer(48));
    ASSERT_TRUE(server);
    auto client = std::move(Client::create(clientFor(*server, 64))).value();
    PoseMessage pose = poseNow(scene);
    client->setPose(pose);
    ASSERT_TRUE(client->waitForFirst(10000.0)) << client->fatal().message();
    auto set = client->newest();
    EXPECT_EQ(set->requestTimestampUs, pose.timestampUs);
    EXPECT_EQ(set->set.views.size(), 4u);
    EXPECT_EQ(set->set.views[0].color.width(), 48);  // the server's cap, below the request
    EXPECT_EQ(client->stats().faceSize, 48);
    // Zero velocity: rendered exactly at the pose, so the warp to it is nearly the render.
    EXPECT_EQ(set->set.pose.eye, pose.pose.eye);
    auto warper = std::move(warp::Warper::create(2)).value();
    CameraDesc d;
    d.eyePos = pose.pose.eye;
    d.targetPos = pose.pose.eye + pose.pose.forward;
    d.width = 64, d.height = 48;
    warp::WarpFrame frame;
    warp::WarpStats stats;
    ASSERT_TRUE(warper->warp(set->set, *Camera::create(d), {}, &frame, &stats).isOk());
    EXPECT_LT(double(stats.holePixels), 0.05 * 64 * 48);
    EXPECT_TRUE(eventually([&] { return client->stats().rttMs >= 0.0; }));
    client->stop();
    EXPECT_TRUE(eventually([&] { return server->stats().sessionsActive == 0; }));
    EXPECT_GE(server->stats().setsSent, 1);
}

TEST(RemoteSession, WideViewsStayWithinWhatClientsDecode) {
    warp::ReferenceSetOptions wide;
    wide.layout = warp::ReferenceLayout::kWide;
    wide.faceSize = 4096;  // 16:9: 7282 wide, above the decoders' 4096
    EXPECT_EQ(maxServedFaceSize(wide), 2304);
    wide.wideAspect = 4096.0f / 300.0f;  // lround(300 x 4096 / 300) is 4096 exactly
    EXPECT_EQ(maxServedFaceSize(wide), 300);
    wide.faceSize = 64;
    EXPECT_EQ(maxServedFaceSize(wide), 64);
    wide.wideAspect = 1e-30f;  // as narrow as a float goes: the face size stands
    EXPECT_EQ(maxServedFaceSize(wide), 64);
    warp::ReferenceSetOptions cube;
    cube.faceSize = 4096;
    EXPECT_EQ(maxServedFaceSize(cube), 4096);

    // A client asking the largest face of a 16:1 wide set gets 256 rows of 4096 and decodes it.
    ServerConfig config = smallServer(4096);
    config.reference.layout = warp::ReferenceLayout::kWide;
    config.reference.wideAspect = 16.0f;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    ClientConfig cc = clientFor(*server, 4096);
    cc.layout = warp::ReferenceLayout::kWide;
    auto client = std::move(Client::create(cc)).value();
    client->setPose(poseNow(*scene::generateFromSpec("office:1")));
    ASSERT_TRUE(client->waitForFirst(10000.0)) << client->fatal().message();
    EXPECT_EQ(client->stats().faceSize, 256);
    auto set = client->newest();
    ASSERT_EQ(set->set.views.size(), 1u);
    EXPECT_EQ(set->set.views[0].color.width(), 4096);
    EXPECT_EQ(set->set.views[0].color.height(), 256);
    client->stop();

    // An aspect that leaves no face of 16 rows within 4096 columns is refused up front.
    config.reference.wideAspect = 300.0f;
    config.reference.faceSize = 32;
    Status refused = checkServerConfig(config);
    EXPECT_FALSE(refused.isOk());
    EXPECT_NE(refused.message().find("wide aspect 300"), std::string::npos) << refused.message();
}

TEST(RemoteSession, PredictionRendersAheadAlongTheVelocity) {
    EXPECT_EQ(predictEye({1, 2, 3}, {1, 0, -2}, 500.0), Vec3(1.5f, 2.0f, 2.0f));
    EXPECT_EQ(predictEye({1, 2, 3}, {1, 0, 0}, 5000.0), Vec3(2.0f, 2.0f, 3.0f));  // clamped to 1 s
    EXPECT_EQ(predictEye({1, 2, 3}, {1, 0, 0}, -5.0), Vec3(1.0f, 2.0f, 3.0f));
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    auto server = startServer(smallServer());
    ASSERT_TRUE(server);
    auto client = std::move(Client::create(clientFor(*server))).value();
    PoseMessage pose = poseNow(scene, {1.0f, 0.0f, 0.0f});
    client->setPose(pose);
    ASSERT_TRUE(client->waitForFirst(10000.0));
    // Moving at 1 m/s along x: the set is rendered ahead of the pose, at most a second's worth.
    Vec3 ahead = client->newest()->set.pose.eye - pose.pose.eye;
    EXPECT_GT(ahead.x, 0.0f);
    EXPECT_LE(ahead.x, 1.0f);
    EXPECT_EQ(ahead.y, 0.0f);
}

// Without a velocity in the poses the server estimates one from successive poses; two valid
// poses 100 us and 100 km apart once implied 1e9 m/s, a set rendered 1e7 m away, or a session
// ended on "camera eye and target coincide". The estimate keeps to the protocol's bound.
TEST(RemoteSession, EstimatedVelocityKeepsToTheProtocolsBound) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    auto server = startServer(smallServer());
    ASSERT_TRUE(server);
    auto client = std::move(Client::create(clientFor(*server))).value();
    PoseMessage first = poseNow(scene);
    first.hasVelocity = false;
    client->setPose(first);
    ASSERT_TRUE(client->waitForFirst(10000.0));
    PoseMessage jump = first;
    jump.timestampUs += 100;
    jump.pose.eye.x += 1e5f;
    client->setPose(jump);
    ASSERT_TRUE(eventually([&] {
        auto newest = client->newest();
        return newest && newest->requestTimestampUs == jump.timestampUs;
    }));
    const float ahead = client->newest()->set.pose.eye.x - jump.pose.eye.x;
    EXPECT_GE(ahead, 0.0f);
    EXPECT_LE(ahead, kMaxSpeedMps);  // a lead of 1 s at most
    EXPECT_EQ(server->stats().sessionsActive, 1);
}

TEST(RemoteSession, HandshakeRefusesVersionAndToken) {
    ServerConfig config = smallServer();
    config.token = "s3cret";
    auto server = startServer(config);
    ASSERT_TRUE(server);
    {
        RawPeer peer(server->port());
        peer.hello("s3cret", 2);
        auto answer = peer.first<ServerHello>();
        ASSERT_TRUE(answer);
        EXPECT_FALSE(answer->accepted);
        EXPECT_NE(answer->reason.find("version 2"), std::string::npos) << answer->reason;
        EXPECT_TRUE(peer.waitClosed());
    }
    for (std::string token : {"", "s3creT", "s3cret-longer"}) {
        ClientConfig cc = clientFor(*server);
        cc.token = token;
        auto client = std::move(Client::create(cc)).value();
        EXPECT_FALSE(client->waitForFirst(10000.0));
        EXPECT_NE(client->fatal().message().find("token"), std::string::npos)
            << client->fatal().message();
    }
    ClientConfig cc = clientFor(*server);
    cc.token = "s3cret";
    auto client = std::move(Client::create(cc)).value();
    client->setPose(poseNow(*scene::generateFromSpec("office:1")));
    EXPECT_TRUE(client->waitForFirst(10000.0)) << client->fatal().message();
    EXPECT_EQ(server->stats().refused, 4);
}

// A plain TCP connection to 127.0.0.1:port, each read bounded by a 5 s timeout.
class RawSocket {
public:
    explicit RawSocket(int port) : mFd(::socket(AF_INET, SOCK_STREAM, 0)) {
        if (mFd < 0) return;
        timeval timeout{5, 0};
        ::setsockopt(mFd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_port = htons(uint16_t(port));
        addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        mConnected = ::connect(mFd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    }
    ~RawSocket() {
        if (mFd >= 0) ::close(mFd);
    }
    RawSocket(const RawSocket&) = delete;
    RawSocket& operator=(const RawSocket&) = delete;

    // Sends `bytes`, then returns what arrives until `until` has (empty: until the server
    // closes).
    std::string exchange(const std::string& bytes, std::string_view until = {}) {
        std::string answer;
        if (!mConnected ||
            ::send(mFd, bytes.data(), bytes.size(), MSG_NOSIGNAL) != ssize_t(bytes.size()))
            return answer;
        char buffer[4096];
        for (int reads = 0; reads < 1000; ++reads) {
            if (!until.empty() && answer.find(until) != std::string::npos) break;
            ssize_t n = ::recv(mFd, buffer, until.empty() ? sizeof buffer : 1, 0);
            if (n <= 0) break;
            answer.append(buffer, size_t(n));
        }
        return answer;
    }

private:
    int mFd;
    bool mConnected = false;
};

// Sends `request` on a plain TCP socket and returns everything the server answers until it
// closes.
std::string rawHttp(int port, const std::string& request) {
    return RawSocket(port).exchange(request);
}

TEST(RemoteSession, PagesAreServedBesideTheWebSocket) {
    static const std::string page = "<!doctype html><title>p</title>";
    ServerConfig config = smallServer();
    config.pages = [](std::string_view path) -> std::optional<HttpFile> {
        if (path != "/") return std::nullopt;
        return HttpFile{{reinterpret_cast<const uint8_t*>(page.data()), page.size()},
                        "text/html; charset=utf-8",
                        {{"Content-Security-Policy", "default-src 'none'"}}};
    };
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    auto server = startServer(config);
    ASSERT_TRUE(server);
    const int port = server->port();

    std::string ok = rawHttp(port, "GET /?ws=/ws HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(ok.rfind("HTTP/1.1 200", 0), 0u) << ok;
    EXPECT_NE(ok.find("Content-Type: text/html; charset=utf-8"), std::string::npos);
    EXPECT_NE(ok.find("Content-Security-Policy: default-src 'none'\r\n"), std::string::npos) << ok;
    EXPECT_EQ(ok.substr(ok.size() - page.size()), page);
    std::string missing = rawHttp(port, "GET /../../etc/passwd HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(missing.rfind("HTTP/1.1 404", 0), 0u) << missing;
    // HEAD: a GET's headers, no body.
    std::string head = rawHttp(port, "HEAD / HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(head.rfind("HTTP/1.1 200", 0), 0u) << head;
    EXPECT_NE(head.find(fmt::format("Content-Length: {}\r\n", page.size())), std::string::npos);
    EXPECT_TRUE(head.ends_with("\r\n\r\n")) << head;
    // Requests the page server does not take, each answered with its status, then closed.
    const std::pair<std::string, std::string> refused[] = {
        {"POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\n\r\n", "405"},
        {"PUT / HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\n\r\nhello", "405"},
        {"GET / HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\n\r\nhello", "413"},
        {"GET / HTTP/1.1\r\nX: " + std::string(16384, 'a') + "\r\n\r\n", "431"},
        {"GET / HTTP/1.1\r\nX: " + std::string(1 << 20, 'a') + "\r\n\r\n", "431"},
        {"\x16\x03\x01 not http\r\n\r\n", "400"},
        {"GET /\r\n\r\n", "400"},
        {"GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
         "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: not-a-key\r\n\r\n",
         "400"},
    };
    for (const auto& [request, status] : refused) {
        std::string answer = rawHttp(port, request);
        EXPECT_EQ(answer.rfind("HTTP/1.1 " + status, 0), 0u) << request.substr(0, 60) << answer;
        if (status == "405") {
            EXPECT_NE(answer.find("Allow: GET, HEAD\r\n"), std::string::npos) << answer;
        }
    }
    // The WebSocket on the same port still serves sessions.
    auto client = servedClient(*server, scene);
    EXPECT_TRUE(client);
}

TEST(RemoteSession, AClientWithoutAPoseGetsTheDefaultViewpoint) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    auto server = startServer(smallServer());
    ASSERT_TRUE(server);
    RawPeer peer(server->port());
    peer.hello();
    ASSERT_TRUE(peer.first<ServerHello>());
    auto set = peer.first<ReferenceSetMessage>();  // no pose sent
    ASSERT_TRUE(set);
    EXPECT_EQ(set->requestTimestampUs, 0u);
    const scene::Viewpoint v = scene::defaultViewpoint(scene);
    EXPECT_EQ(set->set.pose.eye, v.eyePos);
    EXPECT_NEAR(glm::dot(set->set.pose.forward, glm::normalize(v.targetPos - v.eyePos)), 1.0f,
                1e-5f);
}

// The disparity codec byte of a ReferenceSet message's first view: after the message header (13
// bytes), the set header (44) and the view's size (4), at offset 2 of the view
// (docs/remote-protocol.md).
constexpr size_t kFirstViewDisparityCodecOffset = 13 + 44 + 4 + 2;

TEST(RemoteSession, EachClientGetsADisparityCodecItDecodes) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    auto server = startServer(smallServer());
    ASSERT_TRUE(server);
    const struct {
        uint8_t codecs;
        DisparityCodec expected;
    } cases[] = {
        {kAllDisparityCodecs, DisparityCodec::kQuantized16Packed},  // native: the server's codec
        {uint8_t(kAllDisparityCodecs & ~disparityCodecBit(DisparityCodec::kQuantized16Packed)),
         DisparityCodec::kQuantized16},  // a client without q16-packed
        {disparityCodecBit(DisparityCodec::kQuantized16Deflate),
         DisparityCodec::kQuantized16Deflate},  // a browser: no zstd
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(int(c.codecs));
        RawPeer peer(server->port());
        peer.hello({}, kProtocolVersion, c.codecs);
        ASSERT_TRUE(peer.first<ServerHello>());
        peer.send(poseNow(scene));
        ASSERT_TRUE(peer.first<ReferenceSetMessage>());
        const std::vector<uint8_t> raw = peer.firstRawSet();
        ASSERT_GT(raw.size(), kFirstViewDisparityCodecOffset);
        EXPECT_EQ(raw[kFirstViewDisparityCodecOffset], uint8_t(c.expected));
    }
}

TEST(RemoteSession, AbusiveMessagesCloseOnlyTheirSession) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    ServerConfig config = smallServer();
    std::mutex mutex;
    std::vector<std::string> refusals;
    config.onSessionEvent = [&](const SessionEvent& e) {
        std::lock_guard lock(mutex);
        if (e.kind == SessionEvent::Kind::kRefused) refusals.push_back(e.reason);
    };
    auto server = startServer(config);
    ASSERT_TRUE(server);
    auto good = servedClient(*server, scene);
    ASSERT_TRUE(good);

    auto poseBytes = std::move(encodeMessage(poseNow(scene))).value();
    struct Case {
        const char* name;
        bool helloFirst;
        std::vector<uint8_t> bytes;
        const char* word;  // in the Error text
    };
    std::vector<uint8_t> truncated(poseBytes.begin(), poseBytes.end() - 5);
    std::vector<Case> cases = {
        {"malformed", true, {0xff, 1, 2, 3}, "unknown message type"},
        {"truncated", true, truncated, "pose message: truncated"},
        {"empty", true, {}, "empty"},
        {"out of order: pose before hello", false, poseBytes, "before ClientHello"},
        {"out of order: second hello", true, std::move(encodeMessage(ClientHello{})).value(),
         "client hello after the session began"},
        {"server message from a client", true, std::move(encodeMessage(ServerHello{})).value(),
         "unexpected server hello from a client"},
        // Refused by its type, not by a field the server never reads ("protocol version 0").
        {"zeroed server message before hello", false, {2, 0, 0, 0, 0}, "unexpected server hello"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        RawPeer peer(server->port());
        if (c.helloFirst) {
            peer.hello();
            ASSERT_TRUE(peer.first<ServerHello>());
        }
        peer.sendBytes(c.bytes);
        auto error = peer.first<ErrorMessage>();
        ASSERT_TRUE(error);
        EXPECT_EQ(error->kind, ErrorKind::kProtocol);
        EXPECT_NE(error->text.find(c.word), std::string::npos) << error->text;
        EXPECT_TRUE(peer.waitClosed());
    }
    for (bool helloFirst : {true, false}) {
        // Oversized: refused by the WebSocket layer before allocation (close code 1009), counted
        // as a protocol error; before the hello, logged as a refusal.
        RawPeer peer(server->port());
        if (helloFirst) {
            peer.hello();
            ASSERT_TRUE(peer.first<ServerHello>());
        }
        peer.sendBytes(std::vector<uint8_t>(64 * 1024, 3));
        EXPECT_TRUE(peer.waitClosed());
    }
    // Frames that break RFC 6455 section 5 before the hello: unmasked, a reserved opcode,
    // reserved bits set. Beast closes with 1002 (88 02 03 ea); counted and logged as refusals.
    const std::string violations[] = {std::string("\x82\x03"
                                                  "abc",
                                                  5),
                                      std::string("\x83\x80\x01\x02\x03\x04", 6),
                                      std::string("\xc2\x80\x01\x02\x03\x04", 6)};
    for (const std::string& frame : violations) {
        RawSocket socket(server->port());
        std::string upgraded = socket.exchange(
            "GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n",
            "\r\n\r\n");
        ASSERT_EQ(upgraded.rfind("HTTP/1.1 101", 0), 0u) << upgraded;
        EXPECT_EQ(socket.exchange(frame), std::string("\x88\x02\x03\xea", 4));
    }
    // The well-behaved session went on: more sets arrive for new poses.
    EXPECT_TRUE(receivesMore(*good, scene));
    EXPECT_EQ(server->stats().sessionsActive, 1);
    EXPECT_TRUE(eventually([&] {
        return server->stats().protocolErrors == int64_t(cases.size()) + 2 + 3;
    })) << server->stats().protocolErrors;
    auto violationsLogged = [&] {
        std::lock_guard lock(mutex);
        return std::count_if(refusals.begin(), refusals.end(), [](const std::string& r) {
            return r.starts_with("error: WebSocket protocol violation: ");
        });
    };
    EXPECT_TRUE(eventually([&] { return violationsLogged() == 3; })) << violationsLogged();
    std::lock_guard lock(mutex);
    EXPECT_NE(std::find(refusals.begin(), refusals.end(), "error: message larger than 2048 bytes"),
              refusals.end());
}

// A peer that stops reading but keeps sending poses and Pings, while the server pings it every
// 10 ms: one set waits on the socket, and no queue of Pings or Pongs grows behind it.
TEST(RemoteSession, StalledReaderKeepsAtMostOneSetQueued) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    ServerConfig config = smallServer(256);
    config.pingIntervalMs = 10.0;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    RawPeer peer(server->port());
    ASSERT_TRUE(peer.helloThenStopReading(256));
    uint32_t nonce = 0;
    auto poseAndPing = [&] {
        peer.send(poseNow(scene, {0.1f, 0.0f, 0.0f}));
        peer.send(Ping{clientNowUs(), nonce++});
    };
    // Poses keep coming while nothing is read: the socket's buffers fill, then the session
    // stops rendering (no completed send) and the newest pose waits in its one slot.
    sendUntilBackedUp(*server, poseAndPing, 600ms);
    ServerStats s = server->stats();
    EXPECT_GT(s.queuedBytes, 0u) << "the socket never backed up";
    // One set plus the small messages (a Ping, a Pong) queued behind it.
    EXPECT_LE(s.queuedBytes, s.maxSetBytes + 4096);
    EXPECT_LE(s.maxQueuedBytes, s.maxSetBytes + 4096);
    // Two more seconds of 100 server Pings and 100 client Pings a second: nothing more queued
    // but the one unwritten Ping and Pong (OneUnwritten).
    for (int i = 0; i < 200; ++i) poseAndPing(), std::this_thread::sleep_for(10ms);
    EXPECT_LE(server->stats().queuedBytes, s.queuedBytes + 64);
}

// With maxSessionsPerAddress, one peer address holds at most that many sessions: one more is
// refused with kOverloaded naming the address, another address (loopback's 127.0.0.2) is served
// beside it, and a session that ends frees its slot.
TEST(RemoteSession, SessionsFromOneAddressAreLimited) {
    ServerConfig config = smallServer();
    config.maxSessionsPerAddress = 2;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    auto accepted = [](RawPeer& peer) {
        peer.hello();
        auto hello = peer.first<ServerHello>();
        return hello && hello->accepted;
    };
    auto first = std::make_unique<RawPeer>(server->port());
    EXPECT_EQ(first->conn().peerAddress(), "127.0.0.1");  // the server, as the client sees it
    EXPECT_EQ(first->conn().peerGroup(), "127.0.0.1");
    ASSERT_TRUE(accepted(*first));
    RawPeer second(server->port());
    ASSERT_TRUE(accepted(second));
    RawPeer third(server->port());
    third.hello();
    auto error = third.first<ErrorMessage>();
    ASSERT_TRUE(error);
    EXPECT_EQ(error->kind, ErrorKind::kOverloaded);
    EXPECT_EQ(error->text, "too many sessions from 127.0.0.1 (2 at most)");
    EXPECT_TRUE(third.waitClosed());
    RawPeer elsewhere(server->port(), "127.0.0.2");  // another address has slots of its own
    ASSERT_TRUE(accepted(elsewhere));
    first.reset();
    EXPECT_TRUE(eventually([&] { return server->stats().sessionsActive == 2; }));
    RawPeer fourth(server->port());
    EXPECT_TRUE(accepted(fourth));
    EXPECT_EQ(server->stats().refused, 1);
}

// The session log: each hello accepted or refused, and each accepted session's end with what
// it was sent and why it ended, numbered by connection and naming the peer's address.
TEST(RemoteSession, TheSessionLogSaysWhoCameAndHowTheyLeft) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    std::mutex mutex;
    std::vector<SessionEvent> log;
    ServerConfig config = smallServer();
    config.maxSessionsPerAddress = 1;
    config.onSessionEvent = [&](const SessionEvent& e) {
        std::lock_guard lock(mutex);
        log.push_back(e);
    };
    auto server = startServer(config);
    ASSERT_TRUE(server);
    auto logged = [&](size_t n) {
        return eventually([&] {
            std::lock_guard lock(mutex);
            return log.size() >= n;
        });
    };
    {
        RawPeer first(server->port());
        first.hello();
        ASSERT_TRUE(first.first<ServerHello>());
        first.send(poseNow(scene));
        ASSERT_TRUE(first.first<ReferenceSetMessage>());
        RawPeer second(server->port());  // one session per address: refused
        second.hello();
        ASSERT_TRUE(second.first<ErrorMessage>());
        RawPeer early(server->port(), "127.0.0.2");  // a pose before its hello
        early.send(poseNow(scene));
        ASSERT_TRUE(early.waitClosed());
        first.send(Bye{ByeReason::kNormal, "done"});
        ASSERT_TRUE(first.waitClosed());
    }
    ASSERT_TRUE(logged(4));
    RawPeer last(server->port());
    last.hello();
    ASSERT_TRUE(last.first<ServerHello>());
    ASSERT_TRUE(logged(5));
    // The client's own Error ends its session, its text escaped in the log.
    last.send(ErrorMessage{ErrorKind::kProtocol, "bad \xff\x01set"});
    ASSERT_TRUE(logged(6));
    server->stop();

    std::lock_guard lock(mutex);
    ASSERT_EQ(log.size(), 6u);
    using Kind = SessionEvent::Kind;
    EXPECT_EQ(log[0].kind, Kind::kAccepted);
    EXPECT_EQ(log[0].session, 1u);
    EXPECT_EQ(log[0].address, "127.0.0.1");
    EXPECT_EQ(log[0].faceSize, 32);
    EXPECT_EQ(log[1].kind, Kind::kRefused);
    EXPECT_EQ(log[1].session, 2u);
    EXPECT_EQ(log[1].reason, "too many sessions from 127.0.0.1 (1 at most)");
    EXPECT_EQ(log[2].kind, Kind::kRefused);
    EXPECT_EQ(log[2].session, 3u);
    EXPECT_EQ(log[2].address, "127.0.0.2");
    EXPECT_EQ(log[2].reason, "error: pose before ClientHello");
    EXPECT_EQ(log[3].kind, Kind::kEnded);
    EXPECT_EQ(log[3].session, 1u);
    EXPECT_EQ(log[3].reason, "client said goodbye");
    EXPECT_GE(log[3].setsSent, 1);
    EXPECT_GT(log[3].bytesSent, 0);
    EXPECT_GT(log[3].durationS, 0.0);
    EXPECT_EQ(log[4].kind, Kind::kAccepted);
    EXPECT_EQ(log[4].session, 4u);
    EXPECT_EQ(log[5].kind, Kind::kEnded);
    EXPECT_EQ(log[5].session, 4u);
    EXPECT_EQ(log[5].reason, "client error: bad ??set");
    EXPECT_EQ(server->stats().setsSent, log[3].setsSent + log[5].setsSent);
}

// A peer that stops reading is dropped once its socket has taken nothing for the write timeout,
// and its session's slot goes to the next client.
TEST(RemoteSession, APeerThatStopsReadingLosesItsSlot) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    ServerConfig config = smallServer(256);
    config.maxSessions = 1;
    config.writeStallTimeoutMs = 500.0;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    RawPeer peer(server->port());
    ASSERT_TRUE(peer.helloThenStopReading(256));
    // Each pose brings a set until the socket's buffers are full; then one frame waits.
    EXPECT_TRUE(eventually(
        [&] {
            peer.send(poseNow(scene, {0.1f, 0.0f, 0.0f}));
            return server->stats().writeStalls == 1;
        },
        30s));
    peer.conn().setReading(true);  // and finds its connection closed
    EXPECT_TRUE(peer.waitClosed());
    EXPECT_TRUE(eventually([&] { return server->stats().sessionsActive == 0; }));
    EXPECT_EQ(server->stats().queuedBytes, 0u);
    EXPECT_TRUE(servedClient(*server, scene));
}

// A client that says hello and then nothing, answering no ping, holds its slot for the idle
// timeout only; a client that answers the pings keeps its session past it, though it sends no
// pose.
TEST(RemoteSession, ASilentClientLosesItsSlot) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    ServerConfig config = smallServer();
    config.maxSessions = 1;
    config.idleTimeoutMs = 1000.0;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    {
        RawPeer silent(server->port());
        silent.hello();
        ASSERT_TRUE(silent.first<ServerHello>());
        auto bye = silent.first<Bye>();
        ASSERT_TRUE(bye);
        EXPECT_EQ(bye->reason, ByeReason::kIdleTimeout);
        EXPECT_EQ(bye->text, "idle: no message for 1.0 s");
        EXPECT_TRUE(silent.waitClosed());
    }
    EXPECT_EQ(server->stats().idleTimeouts, 1);
    auto client = servedClient(*server, scene);
    ASSERT_TRUE(client);
    std::this_thread::sleep_for(2500ms);
    EXPECT_EQ(server->stats().idleTimeouts, 1);
    EXPECT_TRUE(client->stats().connected);
    EXPECT_TRUE(receivesMore(*client, scene));
}

// Peers refused for a missing token that never read the refusal each hold a connection until
// their close times out; past --max-pending the oldest are dropped at once, and a client with
// the token is served beside the newest.
TEST(RemoteSession, RefusedPeersThatNeverReadArePending) {
    ServerConfig config = smallServer();
    config.token = "abc";
    config.maxPendingConnections = 4;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    std::vector<std::unique_ptr<RawPeer>> peers;
    for (int i = 0; i < 10; ++i) {
        peers.push_back(std::make_unique<RawPeer>(server->port()));
        peers.back()->conn().setReading(false);
        peers.back()->hello();
    }
    EXPECT_TRUE(eventually([&] { return server->stats().refused == 10; }))
        << server->stats().refused;
    EXPECT_TRUE(eventually([&] { return server->stats().pendingDropped == 6; }))
        << server->stats().pendingDropped;
    EXPECT_EQ(server->stats().acceptFailures, 0);
    RawPeer client(server->port());
    client.hello("abc");
    auto hello = client.first<ServerHello>();
    ASSERT_TRUE(hello);
    EXPECT_TRUE(hello->accepted);
}

// Peers that stop reading each hold a set on their sockets; together they stay within the
// server's queue budget, here one set: renders for the others wait until a write completes.
TEST(RemoteSession, StalledReadersQueueNoMoreThanTheBudget) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    ServerConfig config = smallServer(256);
    config.maxQueuedSetBytes = 1;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    std::vector<std::unique_ptr<RawPeer>> peers;
    for (int i = 0; i < 3; ++i) {
        peers.push_back(std::make_unique<RawPeer>(server->port()));
        ASSERT_TRUE(peers.back()->helloThenStopReading(256));
    }
    // Poses from all three until no set has been written for a second: a socket backed up, and
    // renders for the others wait for the budget.
    sendUntilBackedUp(
        *server,
        [&] {
            for (auto& peer : peers) peer->send(poseNow(scene, {0.1f, 0.0f, 0.0f}));
        },
        1s);
    ServerStats s = server->stats();
    EXPECT_GT(s.queuedBytes, 0u) << "the sockets never backed up";
    EXPECT_GT(s.queueWaits, 0);
    // One set (the budget of 1 byte plus one set) and the small messages beside it.
    EXPECT_LE(s.maxQueuedBytes, s.maxSetBytes + 3 * 4096);
}

TEST(RemoteSession, ThirtyTwoConcurrentClients) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    ServerConfig config = smallServer(16);
    config.maxSessions = 32;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    std::vector<std::unique_ptr<Client>> clients;
    for (int i = 0; i < 32; ++i) {
        clients.push_back(std::move(Client::create(clientFor(*server, 16))).value());
        clients.back()->setPose(poseNow(scene));
    }
    for (auto& c : clients) EXPECT_TRUE(c->waitForFirst(20000.0)) << c->fatal().message();
    EXPECT_EQ(server->stats().sessionsActive, 32);
    {
        // The 33rd is refused as overloaded.
        RawPeer extra(server->port());
        extra.hello();
        auto error = extra.first<ErrorMessage>();
        ASSERT_TRUE(error);
        EXPECT_EQ(error->kind, ErrorKind::kOverloaded);
    }
    for (auto& c : clients) c->stop();
    EXPECT_TRUE(eventually([&] { return server->stats().sessionsActive == 0; }));
    EXPECT_LE(server->stats().maxQueuedBytes, 32 * (server->stats().maxSetBytes + 4096));
}

TEST(RemoteSession, AbruptDisconnectsLeaveOthersServed) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    auto server = startServer(smallServer());
    ASSERT_TRUE(server);
    auto good = servedClient(*server, scene);
    ASSERT_TRUE(good);
    for (int i = 0; i < 4; ++i) {
        RawPeer peer(server->port());
        if (i % 2 == 0) {
            peer.hello();
            ASSERT_TRUE(peer.first<ServerHello>());
            peer.send(poseNow(scene));  // a render is in flight as the peer vanishes
        }
        peer.conn().abort();
    }
    EXPECT_TRUE(eventually([&] { return server->stats().sessionsActive == 1; }));
    EXPECT_TRUE(receivesMore(*good, scene));
}

TEST(RemoteSession, ClientReconnectsAfterServerRestart) {
    const scene::Scene scene = *scene::generateFromSpec("office:1");
    auto server = startServer(smallServer());
    ASSERT_TRUE(server);
    const int port = server->port();
    auto client = std::move(Client::create(clientFor(*server))).value();
    client->setPose(poseNow(scene));
    ASSERT_TRUE(client->waitForFirst(10000.0));
    server->stop();
    server.reset();
    EXPECT_TRUE(eventually([&] { return !client->stats().connected; }));
    EXPECT_NE(client->newest(), nullptr);  // the last set stays for the display loop
    // Its attempts meanwhile fail, and it says why.
    EXPECT_TRUE(eventually([&] { return !client->stats().lastError.empty(); }));
    EXPECT_TRUE(client->stats().lastError.starts_with(
        fmt::format("cannot connect to ws://127.0.0.1:{}: ", port)))
        << client->stats().lastError;
    ServerConfig again = smallServer();
    again.port = port;
    server = startServer(again);
    ASSERT_TRUE(server);
    int64_t before = client->stats().referencesReceived;
    EXPECT_TRUE(eventually([&] {
        client->setPose(poseNow(scene));
        return client->stats().referencesReceived > before;
    }));
    EXPECT_EQ(client->stats().connects, 2);
}

// A hostile server: answers every ClientHello, then sends one good set and, on the first
// connection only, a corrupt one; records the Error messages it gets back.
class HostileServer {
public:
    // The first session gets a ServerHello (32-pixel cube4 faces), `good`, then `bad`.
    HostileServer(std::vector<uint8_t> good, std::vector<uint8_t> bad)
        : HostileServer({helloBytes(), good, std::move(bad)}, good) {}
    // The first session gets `firstSession`, each later one a ServerHello and `good`.
    HostileServer(std::vector<std::vector<uint8_t>> firstSession, std::vector<uint8_t> good)
        : mGood(std::move(good)), mFirstSession(std::move(firstSession)) {
        mTransport = std::move(Transport::create()).value();
        ConnectionConfig cc;
        cc.maxMessageBytes = 4096;
        auto port = mTransport->listen("127.0.0.1", 0, cc, [this](std::shared_ptr<Connection> c) {
            ConnectionEvents ev;
            ev.onMessage = [this, c](std::vector<uint8_t>&& m, bool) { onMessage(*c, m); };
            ev.onClosed = [](const Status&) {};
            std::lock_guard lock(mMutex);
            mConnections.push_back(c);
            return ev;
        });
        EXPECT_TRUE(port.isOk());
        mPort = port ? *port : 0;
    }
    ~HostileServer() {
        mConnections.clear();
        mTransport->stop();
    }
    int port() const { return mPort; }
    std::vector<ErrorMessage> errors() {
        std::lock_guard lock(mMutex);
        return mErrors;
    }
    // Sends `bytes` on the newest connection.
    void send(std::vector<uint8_t> bytes) {
        std::lock_guard lock(mMutex);
        if (!mConnections.empty()) mConnections.back()->send(std::move(bytes));
    }
    static std::vector<uint8_t> helloBytes() {
        ServerHello hello;
        hello.faceSize = 32;
        return std::move(encodeMessage(hello)).value();
    }

private:
    void onMessage(Connection& c, const std::vector<uint8_t>& bytes) {
        auto m = decodeMessage(bytes);
        if (!m) return;
        std::lock_guard lock(mMutex);
        if (std::holds_alternative<ClientHello>(*m)) {
            if (mHellos++ == 0) {
                for (const auto& message : mFirstSession) c.send(message);
            } else {
                c.send(helloBytes());
                c.send(mGood);
            }
        } else if (auto* e = std::get_if<ErrorMessage>(&*m)) {
            mErrors.push_back(*e);
        }
    }

    std::unique_ptr<Transport> mTransport;
    std::vector<uint8_t> mGood;
    std::vector<std::vector<uint8_t>> mFirstSession;
    int mPort = 0;
    std::mutex mMutex;
    std::vector<std::shared_ptr<Connection>> mConnections;
    std::vector<ErrorMessage> mErrors;
    int mHellos = 0;
};

// A client of `server` at 32-pixel faces that reconnects within 100 ms.
std::unique_ptr<Client> clientOf(const HostileServer& server) {
    ClientConfig config;
    config.port = server.port();
    config.faceSize = 32;
    config.backoffMinMs = 50.0;
    config.backoffMaxMs = 100.0;
    return std::move(Client::create(config)).value();
}

TEST(RemoteSession, ClientRefusesACorruptSetAndKeepsItsLast) {
    ReferenceSetMessage set;
    set.sequence = 7;
    set.set = renderedSet("office:1", 32);
    std::vector<uint8_t> good = std::move(encodeMessage(set)).value();
    std::vector<uint8_t> bad(good.begin(), good.end() - 9);  // a view cut short
    HostileServer server(good, bad);
    auto client = clientOf(server);
    // The client tells the server what was wrong, hangs up, keeps the good set and reconnects.
    ASSERT_TRUE(eventually([&] { return !server.errors().empty(); }));
    const ErrorMessage e = server.errors().front();
    EXPECT_EQ(e.kind, ErrorKind::kProtocol);
    EXPECT_NE(e.text.find("reference set"), std::string::npos) << e.text;
    // And tells its caller, whose "no reference set" would otherwise give no reason.
    EXPECT_TRUE(eventually([&] {
        return client->stats().lastError == "bad message from the server: " + e.text;
    })) << client->stats().lastError;
    EXPECT_TRUE(eventually([&] { return client->stats().connects >= 2; }));
    // (The good set of the first connection may have been replaced, undecoded, by the bad one.)
    ASSERT_TRUE(eventually([&] { return client->stats().referencesReceived >= 1; }));
    ASSERT_NE(client->newest(), nullptr);
    EXPECT_EQ(client->newest()->sequence, 7u);
    EXPECT_TRUE(client->fatal().isOk());
}

// An Error's text is the server's bytes: the client's message shows them escaped, one line of
// printable ASCII (a --json document could not hold bytes that are not UTF-8).
TEST(RemoteSession, AServersErrorTextIsShownEscaped) {
    ReferenceSetMessage set;
    set.set = renderedSet("office:1", 32);
    std::vector<uint8_t> good = std::move(encodeMessage(set)).value();
    std::vector<uint8_t> error =
        std::move(encodeMessage(ErrorMessage{ErrorKind::kInternal, "broken\xff\xfe\n renderer"}))
            .value();
    HostileServer server(good, error);
    auto client = clientOf(server);
    EXPECT_TRUE(eventually([&] {
        return client->stats().lastError == "server: broken??? renderer";
    })) << client->stats().lastError;
}

// A server that sends a client's message: refused by its type, the session retried.
TEST(RemoteSession, AClientsMessageFromTheServerIsRefused) {
    ReferenceSetMessage set;
    set.set = renderedSet("office:1", 32);
    std::vector<uint8_t> good = std::move(encodeMessage(set)).value();
    HostileServer server(good, {3, 0, 0, 0});  // a Pose's type byte, nothing after it
    auto client = clientOf(server);
    ASSERT_TRUE(eventually([&] { return !server.errors().empty(); }));
    EXPECT_EQ(server.errors().front().text, "unexpected pose from the server");
    EXPECT_TRUE(eventually([&] { return client->stats().connects >= 2; }));
}

// A server out of order, or beyond what it announced: each message is refused with its reason
// and the session retried (a set before the ServerHello was taken and played).
TEST(RemoteSession, TheClientHoldsTheServerToItsHello) {
    ReferenceSetMessage set;
    set.sequence = 7;
    set.set = renderedSet("office:1", 32);
    const std::vector<uint8_t> good = std::move(encodeMessage(set)).value();
    const std::vector<uint8_t> hello = HostileServer::helloBytes();
    ReferenceSetMessage future = set;
    future.requestTimestampUs = UINT64_MAX;
    ReferenceSetMessage larger;
    larger.set = renderedSet("office:1", 64);  // 64-pixel faces after a hello that said 32
    struct Case {
        const char* name;
        std::vector<std::vector<uint8_t>> firstSession;
        const char* error;
    };
    const Case cases[] = {
        {"set before hello", {good, hello}, "reference set before the server accepted the session"},
        {"second hello", {hello, good, hello}, "server hello after the session began"},
        {"faces larger than announced",
         {hello, std::move(encodeMessage(larger)).value()},
         "16384 pixels over the limit 4096"},
        {"pose from the future",
         {hello, std::move(encodeMessage(future)).value()},
         "reference set answers a pose timestamped after its arrival"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        HostileServer server(c.firstSession, good);
        auto client = clientOf(server);
        ASSERT_TRUE(eventually([&] { return !server.errors().empty(); }))
            << client->stats().lastError;
        EXPECT_NE(server.errors().front().text.find(c.error), std::string::npos)
            << server.errors().front().text;
        EXPECT_TRUE(eventually([&] { return client->stats().connects >= 1; }));
        EXPECT_TRUE(client->fatal().isOk());
    }
    // A sequence that does not increase, sent once the first set is decoded.
    HostileServer server({hello, good}, good);
    auto client = clientOf(server);
    ASSERT_TRUE(eventually([&] { return client->stats().referencesReceived == 1; }));
    server.send(good);
    ASSERT_TRUE(eventually([&] { return !server.errors().empty(); }));
    EXPECT_EQ(server.errors().front().text, "reference set 7 after set 7");
}

// Pongs that echo no ping the client sent (a future timestamp, an unsent nonce, a right nonce
// with a wrong timestamp) are not round trips: rtt_ms stays unknown rather than 0.
TEST(RemoteSession, PongsThatEchoNoPingAreNotRoundTrips) {
    ReferenceSetMessage set;
    set.set = renderedSet("office:1", 32);
    const std::vector<uint8_t> good = std::move(encodeMessage(set)).value();
    std::vector<std::vector<uint8_t>> first = {HostileServer::helloBytes()};
    for (Pong forged : {Pong{UINT64_MAX, 0}, Pong{UINT64_MAX, 1}, Pong{1, 1}, Pong{0, 0}})
        first.push_back(std::move(encodeMessage(forged)).value());
    first.push_back(good);  // after the Pongs on the same connection: they were read first
    HostileServer server(first, good);
    auto client = clientOf(server);
    ASSERT_TRUE(eventually([&] { return client->stats().referencesReceived >= 1; }));
    EXPECT_LT(client->stats().rttMs, 0.0);
    EXPECT_TRUE(server.errors().empty());
}

// A server that answers the ClientHello and then says nothing, not even a Pong: the client ends
// the session after its silence timeout and reconnects, and says why.
TEST(RemoteSession, ASilentServerIsLeftAndRetried) {
    auto transport = std::move(Transport::create()).value();
    std::atomic<int> hellos{0};
    ConnectionConfig cc;
    cc.maxMessageBytes = 4096;
    auto port = transport->listen("127.0.0.1", 0, cc, [&](std::shared_ptr<Connection> c) {
        ConnectionEvents ev;
        ev.onMessage = [&hellos, c](std::vector<uint8_t>&& m, bool) {
            auto decoded = decodeMessage(m);
            if (!decoded || !std::holds_alternative<ClientHello>(*decoded)) return;
            ++hellos;
            ServerHello hello;
            hello.faceSize = 32;
            c->send(std::move(encodeMessage(hello)).value());
        };
        ev.onClosed = [](const Status&) {};
        return ev;
    });
    ASSERT_TRUE(port.isOk());
    ClientConfig config;
    config.port = *port;
    config.faceSize = 32;
    config.pingIntervalMs = 100.0;
    config.silenceTimeoutMs = 500.0;
    config.backoffMinMs = 50.0;
    config.backoffMaxMs = 100.0;
    auto client = std::move(Client::create(config)).value();
    EXPECT_TRUE(eventually([&] { return hellos >= 2; }));
    EXPECT_EQ(client->stats().lastError, "no message from the server for 0.5 s");
    config.silenceTimeoutMs = 200.0;  // not above two ping intervals
    EXPECT_FALSE(Client::create(config).isOk());
    client.reset();
    transport->stop();
}

// A server whose kernel takes the TCP connection but which never answers the WebSocket
// handshake: a client stopped meanwhile leaves at once, not after its connect timeout.
TEST(RemoteSession, AClientStopsWhileItsServerIsSlowToAnswer) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    ASSERT_GE(fd, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof addr;
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    ASSERT_EQ(::listen(fd, 4), 0);
    ASSERT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &length), 0);
    ClientConfig config;
    config.port = ntohs(addr.sin_port);
    config.faceSize = 32;
    config.connectTimeoutMs = 20000.0;
    auto client = std::move(Client::create(config)).value();
    EXPECT_FALSE(client->waitForFirst(200.0));
    const auto start = std::chrono::steady_clock::now();
    client->stop();
    EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
    ::close(fd);
}

// A hostile server that answers the ClientHello, stops reading and sends Pings as fast as the
// client reads them: the client's queue of Pongs stays at one (OneUnwritten).
class PingFlooder {
public:
    PingFlooder() {
        mTransport = std::move(Transport::create()).value();
        ConnectionConfig cc;
        cc.maxMessageBytes = 4096;
        auto port = mTransport->listen("127.0.0.1", 0, cc, [this](std::shared_ptr<Connection> c) {
            ConnectionEvents ev;
            ev.onMessage = [this, c](std::vector<uint8_t>&& m, bool) {
                auto decoded = decodeMessage(m);
                if (!decoded || !std::holds_alternative<ClientHello>(*decoded)) return;
                ServerHello hello;
                hello.faceSize = 32;
                c->send(std::move(encodeMessage(hello)).value());
                c->setReading(false);
                std::lock_guard lock(mMutex);
                if (!mFlood.joinable()) mFlood = std::thread([this, c] { flood(*c); });
            };
            ev.onClosed = [](const Status&) {};
            return ev;
        });
        EXPECT_TRUE(port.isOk());
        mPort = port ? *port : 0;
    }
    ~PingFlooder() {
        mStop = true;
        if (mFlood.joinable()) mFlood.join();
        mTransport->stop();
    }
    int port() const { return mPort; }
    uint32_t sent() const { return mSent; }
    static constexpr uint32_t kPings = 400000;  // 6 MB

private:
    // kPings, at most 64 KiB of them queued here at once, within 20 s.
    void flood(Connection& c) {
        const auto end = std::chrono::steady_clock::now() + 20s;
        while (!mStop && mSent < kPings && std::chrono::steady_clock::now() < end) {
            if (c.queuedBytes() > 65536) {
                std::this_thread::sleep_for(1ms);
                continue;
            }
            for (int i = 0; i < 1000; ++i)
                c.send(std::move(encodeMessage(Ping{1, mSent++})).value());
        }
    }

    std::unique_ptr<Transport> mTransport;
    int mPort = 0;
    std::mutex mMutex;
    std::thread mFlood;
    std::atomic<bool> mStop{false};
    std::atomic<uint32_t> mSent{0};
};

TEST(RemoteSession, AServerThatStopsReadingGetsNoQueueOfPongs) {
    PingFlooder server;
    ClientConfig config;
    config.port = server.port();
    config.faceSize = 32;
    config.pingIntervalMs = 10.0;
    auto client = std::move(Client::create(config)).value();
    client->setPose(poseNow(*scene::generateFromSpec("office:1")));
    // The Pongs of the flood fill the sockets' buffers (about 4 MiB on loopback) long before
    // the client has read the last Ping; watch its queue until two seconds after that.
    size_t most = 0;
    auto watch = [&] {
        most = std::max(most, client->stats().queuedBytes);
        return false;
    };
    ASSERT_TRUE(eventually(
        [&] {
            watch();
            return server.sent() >= PingFlooder::kPings;
        },
        25s));
    eventually(watch, 2s);
    // A Ping, a Pong and the poses' bound (kMaxQueuedPoseBytes) at most.
    EXPECT_LE(most, 4096u + 256u);
    client->stop();
}

TEST(RemoteSession, LinkEmulationDelaysBothDirections) {
    ServerConfig config = smallServer();
    config.link.latencyMs = 50.0;
    auto server = startServer(config);
    ASSERT_TRUE(server);
    auto client = std::move(Client::create(clientFor(*server))).value();
    ASSERT_TRUE(eventually([&] { return client->stats().rttMs >= 0.0; }));
    // 50 ms each way on the server's socket: about 100 ms round trip (generous bounds: this
    // checks the emulation is applied in both directions, not the machine's timing).
    EXPECT_GE(client->stats().rttMs, 95.0);
    EXPECT_LE(client->stats().rttMs, 400.0);
}

TEST(RemoteSession, ServersShareTheCallersScene) {
    const auto scene = std::make_shared<const scene::Scene>(*scene::generateFromSpec("office:1"));
    for (int i = 0; i < 2; ++i) {  // one server after another, as bench remote's sessions
        auto server = Server::create(scene, smallServer());
        ASSERT_TRUE(server.isOk()) << server.status().toString();
        EXPECT_EQ(scene.use_count(), 2);  // held, not copied
    }
    EXPECT_EQ(scene.use_count(), 1);
    auto none = Server::create(std::shared_ptr<const scene::Scene>(), smallServer());
    ASSERT_FALSE(none.isOk());
    EXPECT_NE(none.status().message().find("no scene"), std::string::npos);
}

TEST(RemoteSession, BadConfigurationsAreRefused) {
    ServerConfig c = smallServer();
    c.bind = "not-an-address";
    EXPECT_FALSE(Server::create(*scene::generateFromSpec("office:1"), c).isOk());
    EXPECT_FALSE(checkServerConfig(c).isOk());  // refused before anything is started
    EXPECT_TRUE(checkBindAddress("::1").isOk());
    EXPECT_FALSE(checkBindAddress("300.1.1.1").isOk());
    c = smallServer();
    c.link.latencyMs = -1.0;
    EXPECT_FALSE(checkServerConfig(c).isOk());
    c = smallServer(8);
    EXPECT_FALSE(checkServerConfig(c).isOk());
    c = smallServer();
    c.writeStallTimeoutMs = 0.0;
    EXPECT_FALSE(checkServerConfig(c).isOk());
    c = smallServer();
    c.prediction = Prediction(2);
    EXPECT_EQ(checkServerConfig(c).message(), "unknown prediction");
    for (double idleMs : {std::nan(""), 999.0, 3601e3}) {
        c = smallServer();
        c.idleTimeoutMs = idleMs;
        EXPECT_FALSE(checkServerConfig(c).isOk()) << idleMs;
    }
    c = smallServer();
    c.pingIntervalMs = 600.0;
    c.idleTimeoutMs = 1200.0;  // a pong may come just after a second ping interval
    EXPECT_FALSE(checkServerConfig(c).isOk());
    c = smallServer();
    c.maxQueuedSetBytes = 0;
    EXPECT_FALSE(checkServerConfig(c).isOk());
    c = smallServer();
    c.maxPendingConnections = 0;
    EXPECT_FALSE(checkServerConfig(c).isOk());
    for (int perAddress : {-1, 1025}) {
        c = smallServer();
        c.maxSessionsPerAddress = perAddress;
        EXPECT_FALSE(checkServerConfig(c).isOk()) << perAddress;
    }
    EXPECT_FALSE(parseWsUrl("http://x:1").isOk());
    EXPECT_FALSE(parseWsUrl("ws://x:99999").isOk());
    EXPECT_FALSE(parseWsUrl("ws://:80").isOk());
    auto u = parseWsUrl("ws://127.0.0.1:8080/a");
    ASSERT_TRUE(u.isOk());
    EXPECT_EQ(u->host, "127.0.0.1");
    EXPECT_EQ(u->port, 8080);
    EXPECT_EQ(u->path, "/a");
    // IPv6 in brackets (RFC 3986), with and without a port; without them, one line saying so.
    u = parseWsUrl("ws://[::1]:8080/a");
    ASSERT_TRUE(u.isOk()) << u.status().message();
    EXPECT_EQ(u->host, "::1");
    EXPECT_EQ(u->port, 8080);
    EXPECT_EQ(u->path, "/a");
    EXPECT_EQ(authority(u->host, u->port), "[::1]:8080");
    EXPECT_EQ(authority("127.0.0.1", 80), "127.0.0.1:80");
    u = parseWsUrl("ws://[fe80::1]");
    ASSERT_TRUE(u.isOk()) << u.status().message();
    EXPECT_EQ(u->host, "fe80::1");
    EXPECT_EQ(u->port, 80);
    const std::pair<std::string, std::string> badUrls[] = {
        {"ws://::1:8080/", "without brackets"},
        {"ws://[::1:8080/", "no ']'"},
        {"ws://[::1]8080/", "more after ']'"},
        {"ws://[]:8080/", "no host"},
        {"ws://[::1]:/", "port ''"},
        {"ws://[::1]:65536/", "port '65536'"},
    };
    for (const auto& [url, problem] : badUrls) {
        auto r = parseWsUrl(url);
        ASSERT_FALSE(r.isOk()) << url;
        EXPECT_NE(r.status().message().find(problem), std::string::npos) << r.status().message();
    }
    // A client that cannot connect keeps trying (bounded backoff) and never fails for good.
    ClientConfig cc;
    cc.port = 1;
    cc.backoffMaxMs = 200.0;
    auto client = std::move(Client::create(cc)).value();
    EXPECT_FALSE(client->waitForFirst(300.0));
    EXPECT_TRUE(client->fatal().isOk());
}

}  // namespace
}  // namespace plx::remote
