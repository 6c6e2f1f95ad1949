// The listener against raw TCP peers on loopback (127.0.0.1, a free port). The write timeout: a
// reader that keeps taking bytes, however slowly, keeps its connection; one that stops is
// dropped. The pending limit: past it, the oldest connections that sent nothing are dropped, not
// the ones that did. A client's source address. Every wait is bounded; nothing here measures
// speed.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <plx/remote/transport.h>
#include <plx_test/loopback.h>

namespace plx::remote {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using plx::testing::closedByPeer;
using plx::testing::silentConnection;

// Several times what the sender's socket buffer (tcp_wmem's 4 MiB at most) and the reader's
// small one hold, so the write waits on the reader. Linux wakes a writer blocked on a full
// buffer only when a third or more of it is free again: a reader that takes 64 KiB every 10 ms
// frees that within a fraction of the timeout.
constexpr size_t kMessageBytes = 24u << 20;
constexpr double kStallTimeoutMs = 1000.0;

// A listener whose one accepted connection is sent a message; records how the send and the
// connection ended.
class Listener {
public:
    explicit Listener(const std::string& host = "127.0.0.1") {
        mTransport = std::move(Transport::create()).value();
        ConnectionConfig config;
        config.writeStallTimeoutMs = kStallTimeoutMs;
        auto port = mTransport->listen(host, 0, config, [this](auto conn) {
            std::lock_guard lock(mMutex);
            mConn = conn;
            mChanged.notify_all();
            ConnectionEvents events;
            events.onClosed = [this](const Status& why) {
                std::lock_guard closedLock(mMutex);
                mClosed = why;
                mChanged.notify_all();
            };
            return events;
        });
        EXPECT_TRUE(port.isOk()) << port.status().message();
        mPort = port ? *port : 0;
    }
    ~Listener() { mTransport->stop(); }

    int port() const { return mPort; }

    // Sends kMessageBytes once the connection is accepted; false if none came.
    bool sendMessage() {
        std::unique_lock lock(mMutex);
        if (!mChanged.wait_for(lock, 10s, [&] { return mConn != nullptr; })) return false;
        mSentAt = Clock::now();
        mConn->send(std::vector<uint8_t>(kMessageBytes, 7), [this](const Status& s) {
            std::lock_guard sentLock(mMutex);
            mSent = s;
            mSendMs = std::chrono::duration<double, std::milli>(Clock::now() - mSentAt).count();
            mChanged.notify_all();
        });
        return true;
    }
    // How the send ended (waits, bounded); nullopt if it has not.
    std::optional<Status> sent(std::chrono::milliseconds limit) {
        std::unique_lock lock(mMutex);
        mChanged.wait_for(lock, limit, [&] { return mSent.has_value(); });
        return mSent;
    }
    double sendMs() {
        std::lock_guard lock(mMutex);
        return mSendMs;
    }
    // The accepted connection's peer address (waits, bounded); empty if none came.
    std::string peerAddress() {
        std::unique_lock lock(mMutex);
        if (!mChanged.wait_for(lock, 10s, [&] { return mConn != nullptr; })) return {};
        return mConn->peerAddress();
    }
    std::optional<Status> closed(std::chrono::milliseconds limit) {
        std::unique_lock lock(mMutex);
        mChanged.wait_for(lock, limit, [&] { return mClosed.has_value(); });
        return mClosed;
    }

private:
    std::unique_ptr<Transport> mTransport;
    int mPort = 0;
    std::mutex mMutex;
    std::condition_variable mChanged;
    std::shared_ptr<Connection> mConn;
    Clock::time_point mSentAt;
    std::optional<Status> mSent, mClosed;
    double mSendMs = 0.0;
};

// A WebSocket client on a plain socket with a 64 KiB receive buffer (no autotuning): it completes
// the handshake, then reads only when told to.
class RawReader {
public:
    explicit RawReader(int port) {
        mFd = socket(AF_INET, SOCK_STREAM, 0);
        int buffer = 64 * 1024;
        setsockopt(mFd, SOL_SOCKET, SO_RCVBUF, &buffer, sizeof buffer);
        timeval timeout{2, 0};
        setsockopt(mFd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_port = htons(uint16_t(port));
        addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        mOk = connect(mFd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 && handshake();
    }
    ~RawReader() { close(mFd); }

    bool ok() const { return mOk; }
    // Sends one binary message of at most 125 bytes (one frame, masked with a zero key).
    bool sendBinary(const std::vector<uint8_t>& payload) {
        std::vector<uint8_t> frame = {0x82, uint8_t(0x80 | payload.size()), 0, 0, 0, 0};
        frame.insert(frame.end(), payload.begin(), payload.end());
        return payload.size() <= 125 &&
               send(mFd, frame.data(), frame.size(), 0) == ssize_t(frame.size());
    }
    // Reads what is there (at most 64 KiB); the bytes read, 0 at the end or after 2 s of nothing.
    size_t readSome() {
        static thread_local std::vector<char> sink(64 * 1024);
        ssize_t n = recv(mFd, sink.data(), sink.size(), 0);
        return n > 0 ? size_t(n) : 0;
    }

private:
    bool handshake() {
        const std::string request =
            "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
        if (send(mFd, request.data(), request.size(), 0) != ssize_t(request.size())) return false;
        std::string response;
        char c;
        while (response.size() < 4096 && !response.ends_with("\r\n\r\n")) {
            if (recv(mFd, &c, 1, 0) != 1) return false;
            response += c;
        }
        return response.starts_with("HTTP/1.1 101");
    }

    int mFd = -1;
    bool mOk = false;
};

TEST(TransportWriteTimeout, ASlowReaderThatKeepsReadingIsNotCut) {
    Listener listener;
    RawReader reader(listener.port());
    ASSERT_TRUE(reader.ok());
    ASSERT_TRUE(listener.sendMessage());
    // At most 64 KiB every 10 ms: the socket takes each frame within a part of the timeout,
    // the whole message in several times it.
    size_t received = 0;
    const auto end = Clock::now() + 60s;
    while (received < kMessageBytes && Clock::now() < end) {
        const size_t n = reader.readSome();
        if (n == 0) break;
        received += n;
        std::this_thread::sleep_for(10ms);
    }
    EXPECT_GE(received, kMessageBytes);
    auto sent = listener.sent(10s);
    ASSERT_TRUE(sent);
    EXPECT_TRUE(sent->isOk()) << sent->message();
    EXPECT_GT(listener.sendMs(), 2.0 * kStallTimeoutMs) << "the message never waited on the reader";
    EXPECT_FALSE(listener.closed(0ms));
}

TEST(TransportWriteTimeout, AReaderThatStopsIsDropped) {
    Listener listener;
    RawReader reader(listener.port());
    ASSERT_TRUE(reader.ok());
    ASSERT_TRUE(listener.sendMessage());
    auto closed = listener.closed(20s);
    ASSERT_TRUE(closed) << "still connected";
    EXPECT_TRUE(isWriteStall(*closed)) << closed->message();
    EXPECT_NE(closed->message().find("no 64 KiB written in 1000 ms"), std::string::npos)
        << closed->message();
    auto sent = listener.sent(1s);
    ASSERT_TRUE(sent);
    EXPECT_FALSE(sent->isOk());
}

TEST(TransportWriteTimeout, OutOfRangeTimeoutsAreRefused) {
    EXPECT_TRUE(checkWriteStallTimeout(100.0).isOk());
    EXPECT_TRUE(checkWriteStallTimeout(3600e3).isOk());
    for (double bad : {0.0, 99.0, 3600e3 + 1.0, -1.0, std::numeric_limits<double>::quiet_NaN()}) {
        Status s = checkWriteStallTimeout(bad);
        EXPECT_FALSE(s.isOk()) << bad;
        EXPECT_NE(s.message().find("write timeout"), std::string::npos) << s.message();
    }
}

// A listener that lets `maxPending` connections wait for their first message or their close,
// and counts the messages and closes of those that got past their WebSocket handshake. With
// `refuse`, it answers each first message by closing, as a server refuses a hello.
class PendingListener {
public:
    explicit PendingListener(int maxPending, bool refuse = false) {
        mTransport = std::move(Transport::create()).value();
        ConnectionConfig config;
        config.maxPendingConnections = maxPending;
        config.handshakeTimeoutMs = 60000.0;  // no pending connection times out during a test
        auto port = mTransport->listen("127.0.0.1", 0, config, [this, refuse](auto conn) {
            {
                std::lock_guard lock(mMutex);
                mAccepted.push_back(conn);
            }
            ConnectionEvents events;
            events.onMessage = [this, refuse, weak = std::weak_ptr(conn)](auto&&, bool) {
                if (auto c = weak.lock(); c && refuse) c->close();
                bump(mMessages);
            };
            events.onClosed = [this](const Status&) { bump(mClosed); };
            return events;
        });
        EXPECT_TRUE(port.isOk()) << port.status().message();
        mPort = port ? *port : 0;
    }
    ~PendingListener() { mTransport->stop(); }

    int port() const { return mPort; }
    Transport& transport() { return *mTransport; }
    // Waits (bounded) until `n` messages arrived; false if they did not.
    bool messages(int n) {
        std::unique_lock lock(mMutex);
        return mChanged.wait_for(lock, 5s, [&] { return mMessages >= n; });
    }
    int closed() {
        std::lock_guard lock(mMutex);
        return mClosed;
    }
    // Closes the `i`th connection accepted (a session ending it: a refusal or goodbye written).
    void closeAccepted(size_t i) {
        std::lock_guard lock(mMutex);
        if (auto c = mAccepted.at(i).lock()) c->close();
    }
    // Waits (bounded) until the listener dropped `n` pending connections; the count it reached.
    int64_t pendingDropped(int64_t n) {
        const auto end = Clock::now() + 5s;
        while (mTransport->listenerStats().pendingDropped < n && Clock::now() < end)
            std::this_thread::sleep_for(5ms);
        return mTransport->listenerStats().pendingDropped;
    }

private:
    void bump(int& counter) {
        std::lock_guard lock(mMutex);
        ++counter;
        mChanged.notify_all();
    }

    std::unique_ptr<Transport> mTransport;
    int mPort = 0;
    std::mutex mMutex;
    std::condition_variable mChanged;
    int mMessages = 0, mClosed = 0;
    std::vector<std::weak_ptr<Connection>> mAccepted;
};

// A client bound to a source address reaches the server from it (Linux's loopback holds
// 127.0.0.0/8; nothing leaves the machine); a source that is not an IP address, has no address of
// its family at the host, or is not local is one error naming it.
TEST(TransportConnect, AClientConnectsFromItsSourceAddress) {
    Listener listener;
    auto transport = std::move(Transport::create()).value();
    ConnectionConfig config;
    config.sourceAddress = "127.0.0.2";
    auto connected = transport->connect("127.0.0.1", listener.port(), "/", config, {});
    ASSERT_TRUE(connected.isOk()) << connected.status().message();
    const std::shared_ptr<Connection> conn = *connected;
    EXPECT_EQ(listener.peerAddress(), "127.0.0.2");
    EXPECT_EQ(conn->peerAddress(), "127.0.0.1");
    // The same address written IPv4-mapped, as a dual-stack host may list it.
    Listener another;
    config.sourceAddress = "::ffff:127.0.0.3";
    ASSERT_TRUE(transport->connect("127.0.0.1", another.port(), "/", config, {}).isOk());
    EXPECT_EQ(another.peerAddress(), "127.0.0.3");
    EXPECT_TRUE(checkSourceAddress("::ffff:127.0.0.3").isOk());

    const std::string to = fmt::format(" to ws://127.0.0.1:{}: ", listener.port());
    std::vector<std::pair<std::string, std::string>> refused = {
        {"loopback", "source address 'loopback' is not an IP address"},
        {"::1", "cannot connect from ::1" + to}};
    std::ifstream nonlocal("/proc/sys/net/ipv4/ip_nonlocal_bind");
    if (int allowed = 1; nonlocal >> allowed && allowed == 0)  // else binding it succeeds
        refused.emplace_back("192.0.2.1", "cannot connect from 192.0.2.1" + to);
    for (const auto& [source, error] : refused) {
        config.sourceAddress = source;
        auto bad = transport->connect("127.0.0.1", listener.port(), "/", config, {});
        ASSERT_FALSE(bad.isOk()) << source;
        EXPECT_TRUE(bad.status().message().starts_with(error)) << bad.status().message();
    }
}

// Whether this host has IPv6 loopback (a container may not).
bool hasIpv6Loopback() {
    const int fd = socket(AF_INET6, SOCK_STREAM, 0);
    if (fd < 0) return false;
    sockaddr_in6 address{};
    address.sin6_family = AF_INET6;
    address.sin6_addr = in6addr_loopback;
    const bool bound = bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
    close(fd);
    return bound;
}

// The URL form RFC 3986 gives an IPv6 host, as `parallax serve --bind ::1` prints it, reaches it.
TEST(TransportConnect, AnIPv6HostInBracketsIsReached) {
    if (!hasIpv6Loopback()) GTEST_SKIP() << "no IPv6 loopback on this host";
    Listener listener("::1");
    auto url = parseWsUrl(fmt::format("ws://{}/session", authority("::1", listener.port())));
    ASSERT_TRUE(url.isOk()) << url.status().message();
    EXPECT_EQ(url->host, "::1");
    auto transport = std::move(Transport::create()).value();
    auto connected = transport->connect(url->host, url->port, url->path, {}, {});
    ASSERT_TRUE(connected.isOk()) << connected.status().message();
    EXPECT_EQ(listener.peerAddress(), "::1");
    EXPECT_EQ((*connected)->peerAddress(), "::1");
}

TEST(TransportPending, TheOldestSilentConnectionsAreDroppedPastTheLimit) {
    PendingListener listener(4);
    std::vector<int> silent;
    for (int i = 0; i < 10; ++i) silent.push_back(silentConnection(listener.port()));
    ASSERT_EQ(std::count(silent.begin(), silent.end(), -1), 0);
    EXPECT_EQ(listener.pendingDropped(6), 6);
    for (int i = 0; i < 6; ++i) EXPECT_TRUE(closedByPeer(silent[i], 2s)) << i;
    for (int i = 6; i < 10; ++i) EXPECT_FALSE(closedByPeer(silent[i], 100ms)) << i;

    // A client that completes its handshake and says something is no longer pending: ten more
    // silent connections drop the older silent ones, and then each other, never it.
    auto client = listener.transport().connect("127.0.0.1", listener.port(), "/",
                                               ConnectionConfig{}, ConnectionEvents{});
    ASSERT_TRUE(client.isOk()) << client.status().message();
    (*client)->send({1, 2, 3});
    ASSERT_TRUE(listener.messages(1));
    EXPECT_EQ(listener.pendingDropped(7), 7);  // its arrival dropped the oldest silent one
    for (int i = 0; i < 10; ++i) silent.push_back(silentConnection(listener.port()));
    EXPECT_EQ(listener.pendingDropped(16), 16);
    EXPECT_FALSE(closedByPeer(silent.back(), 100ms));
    (*client)->send({4});
    EXPECT_TRUE(listener.messages(2));
    EXPECT_EQ(listener.closed(), 0);
    EXPECT_EQ(listener.transport().listenerStats().acceptFailures, 0);
    (*client)->abort();
    for (int fd : silent) close(fd);
}

// A connection that said something is not pending, until a session closes it (a refusal or a
// goodbye written, the peer's close awaited): the limit applies then, not at the next accept.
TEST(TransportPending, AConnectionClosedAfterItsFirstMessageCountsAgain) {
    PendingListener listener(2);
    auto client = listener.transport().connect("127.0.0.1", listener.port(), "/",
                                               ConnectionConfig{}, ConnectionEvents{});
    ASSERT_TRUE(client.isOk()) << client.status().message();
    (*client)->send({1});
    ASSERT_TRUE(listener.messages(1));
    const int silent[] = {silentConnection(listener.port()), silentConnection(listener.port())};
    ASSERT_GE(std::min(silent[0], silent[1]), 0);
    std::this_thread::sleep_for(100ms);  // both accepted: two pending, the limit
    EXPECT_EQ(listener.transport().listenerStats().pendingDropped, 0);
    listener.closeAccepted(0);  // three pending: the oldest is dropped at once
    EXPECT_EQ(listener.pendingDropped(1), 1);
    for (int fd : silent) close(fd);
}

// Past the limit the connections dropped are the oldest of the address with the most: a flood
// from 127.0.0.2 drops its own, never an older silent connection from 127.0.0.1.
TEST(TransportPending, AFloodFromOneAddressDropsItsOwnConnections) {
    PendingListener listener(4);
    const int other = silentConnection(listener.port(), 1);
    ASSERT_GE(other, 0);
    std::vector<int> flood;
    for (int i = 0; i < 10; ++i) flood.push_back(silentConnection(listener.port(), 2));
    ASSERT_EQ(std::count(flood.begin(), flood.end(), -1), 0);
    EXPECT_EQ(listener.pendingDropped(7), 7);
    EXPECT_FALSE(closedByPeer(other, 100ms));
    for (int i = 0; i < 7; ++i) EXPECT_TRUE(closedByPeer(flood[i], 2s)) << i;
    for (int i = 7; i < 10; ++i) EXPECT_FALSE(closedByPeer(flood[i], 100ms)) << i;
    close(other);
    for (int fd : flood) close(fd);
}

// The per-address limits count an IPv4 address alone and an IPv6 address with its /64.
TEST(TransportPending, AddressGroupsAreIPv4AddressesAndIPv6Slash64s) {
    EXPECT_EQ(addressGroup("127.0.0.1"), "127.0.0.1");
    EXPECT_EQ(addressGroup("2001:db8:1:2:aaaa:bbbb:cccc:dddd"), "2001:db8:1:2::/64");
    EXPECT_EQ(addressGroup("2001:db8:1:2::1"), addressGroup("2001:db8:1:2:ffff::9"));
    EXPECT_NE(addressGroup("2001:db8:1:2::1"), addressGroup("2001:db8:1:3::1"));
    EXPECT_EQ(addressGroup("::1"), "::/64");
    EXPECT_EQ(addressGroup(""), "");
    EXPECT_EQ(addressGroup("no address"), "no address");
}

// Peers refused at their first message that never read the refusal: each waits for its close
// (until the handshake timeout) as pending, and past the limit the oldest are dropped at once.
TEST(TransportPending, RefusedPeersThatNeverReadAreDroppedPastTheLimit) {
    PendingListener listener(4, /*refuse=*/true);
    std::vector<std::unique_ptr<RawReader>> peers;
    for (int i = 0; i < 10; ++i) {
        peers.push_back(std::make_unique<RawReader>(listener.port()));
        ASSERT_TRUE(peers.back()->ok()) << i;
        ASSERT_TRUE(peers.back()->sendBinary({1, 2, 3})) << i;
        ASSERT_TRUE(listener.messages(i + 1)) << i;
    }
    EXPECT_EQ(listener.pendingDropped(6), 6);
    EXPECT_EQ(listener.closed(), 6);  // the four newest still wait for their peers' close
}

TEST(TransportPending, OutOfRangeLimitsAreRefused) {
    auto transport = std::move(Transport::create()).value();
    for (int bad : {0, -1, 65537}) {
        ConnectionConfig config;
        config.maxPendingConnections = bad;
        auto port =
            transport->listen("127.0.0.1", 0, config, [](auto) { return ConnectionEvents{}; });
        ASSERT_FALSE(port.isOk()) << bad;
        EXPECT_NE(port.status().message().find("max pending connections"), std::string::npos)
            << port.status().message();
    }
    EXPECT_TRUE(checkMaxPending(1).isOk());
    EXPECT_TRUE(checkMaxPending(65536).isOk());
}

}  // namespace
}  // namespace plx::remote
