// HttpFetcher against nginx serving a built database (byte-for-byte ranges, limit_rate
// throttling) and against a scripted raw-socket server on 127.0.0.1 that answers wrongly.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <plx_test/nginx.h>

#include <plx/ptm/format.h>
#include <plx/scene/generators.h>
#include <plx/stream/cells.h>
#include <plx/stream/client.h>
#include <plx/stream/database.h>
#include <plx/stream/http_fetch.h>
#include <plx/stream/link_simulator.h>
#include <plx/stream/visibility.h>

namespace plx::stream {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

fs::path freshTempDir(const std::string& name) {
    fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::vector<uint8_t> fileBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Polls until `count` completions arrived; a 20 s guard keeps a broken fetcher from hanging the
// test (the fetcher's own timeouts are far shorter).
std::vector<FetchCompletion> waitFor(Fetcher& f, size_t count) {
    std::vector<FetchCompletion> all;
    const auto giveUp = Clock::now() + std::chrono::seconds(20);
    while (all.size() < count && Clock::now() < giveUp) {
        for (auto& c : f.poll(0.0)) all.push_back(std::move(c));
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return all;
}

FetchCompletion fetchOne(Fetcher& f, FetchRequest r) {
    f.submit(std::move(r), 0.0);
    auto done = waitFor(f, 1);
    EXPECT_EQ(done.size(), 1u);
    return done.empty() ? FetchCompletion{} : std::move(done[0]);
}

TEST(HttpUrl, ParsesAndRefuses) {
    auto u = parseHttpUrl("http://127.0.0.1:8080/db");
    ASSERT_TRUE(u.isOk()) << u.status().toString();
    EXPECT_EQ(u->host, "127.0.0.1");
    EXPECT_EQ(u->port, 8080);
    EXPECT_EQ(u->basePath, "/db/");
    auto plain = parseHttpUrl("http://example.org");
    ASSERT_TRUE(plain.isOk());
    EXPECT_EQ(plain->port, 80);
    EXPECT_EQ(plain->basePath, "/");
    for (const char* bad :
         {"https://h/db", "ftp://h/", "http://", "http://:80/", "http://h:0/", "http://h:65536/",
          "http://h:8x/", "http://user@h/", "http://h/a?b", "http://h/a#b", "http://h/%2e",
          "http://h/../x", "http://h/a/./b", "http://[::1]:80/", "http://h/a b", "db"}) {
        auto r = parseHttpUrl(bad);
        EXPECT_FALSE(r.isOk()) << bad;
        if (!r.isOk()) {
            EXPECT_EQ(r.status().message().find('\n'), std::string::npos);
        }
    }
    for (const char* credentials : {"http://user@h/", "http://user:pw@127.0.0.1:1/x"}) {
        EXPECT_NE(parseHttpUrl(credentials).status().message().find("user:pass@"),
                  std::string::npos)
            << credentials;
    }
    EXPECT_FALSE(openHttpFetcher("https://h/db").isOk());
    HttpOptions zero;
    zero.readTimeoutS = 0;
    EXPECT_FALSE(openHttpFetcher("http://127.0.0.1:1/", zero).isOk());
}

TEST(HttpContentRange, ExactMatchOnlyAndEveryPrefixRefused) {
    const ByteRange want{100, 199};
    const std::string good = "bytes 100-199/1000";
    EXPECT_TRUE(checkContentRange(good, want).isOk());
    EXPECT_TRUE(checkContentRange("bytes 100-199/*", want).isOk());
    for (size_t n = 0; n < good.size(); ++n) {
        EXPECT_FALSE(checkContentRange(good.substr(0, n), want).isOk()) << n;
    }
    for (const char* bad :
         {"bytes 100-198/1000", "bytes 101-199/1000", "bytes 100-199/199", "bytes 100-199/-5",
          "bytes -100-199/1000", "bytes 100-199", "bits 100-199/1000", "bytes 199-100/1000",
          "bytes 100-199/1000x", "bytes 100-99999999999999999999/*", "bytes  100-199/1000"}) {
        EXPECT_FALSE(checkContentRange(bad, want).isOk()) << bad;
    }
}

// A one-thread server on 127.0.0.1 that answers every request with a scripted reply.
struct Reply {
    std::string bytes;    // sent as one write; empty with `silent`
    bool silent = false;  // never answers (the client must time out)
    bool reset = false;   // after sending, closes with RST (SO_LINGER 0)
    bool close = false;   // after sending, closes in order (FIN)
    int dripMs = 0;       // > 0: the headers at once, then a byte of the body every dripMs
};

class RawServer {
public:
    explicit RawServer(std::function<Reply(const std::string&)> script)
        : mScript(std::move(script)) {
        mListen = socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        EXPECT_EQ(bind(mListen, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
        socklen_t len = sizeof a;
        getsockname(mListen, reinterpret_cast<sockaddr*>(&a), &len);
        mPort = ntohs(a.sin_port);
        listen(mListen, 8);
        mThread = std::thread([this] { serve(); });
    }
    ~RawServer() {
        mStop = true;
        mThread.join();
        close(mListen);
    }
    std::string url() const { return "http://127.0.0.1:" + std::to_string(mPort) + "/db"; }
    int requests() const { return mRequests; }
    int connections() const { return mConnections; }

private:
    // Waits up to 50 ms for `fd` to be readable; false on timeout.
    static bool readable(int fd) {
        pollfd p{fd, POLLIN, 0};
        return poll(&p, 1, 50) > 0;
    }

    void serve() {
        while (!mStop) {
            if (!readable(mListen)) continue;
            int fd = accept(mListen, nullptr, nullptr);
            if (fd < 0) continue;
            ++mConnections;
            serveConnection(fd);
        }
    }

    // Reads requests (headers only, at most 8 KiB) and answers each until the peer closes.
    void serveConnection(int fd) {
        std::string in;
        char buf[4096];
        while (!mStop) {
            if (!readable(fd)) continue;
            ssize_t n = recv(fd, buf, sizeof buf, 0);
            if (n <= 0 || in.size() > 8192) break;
            in.append(buf, size_t(n));
            size_t end = in.find("\r\n\r\n");
            if (end == std::string::npos) continue;
            std::string request = in.substr(0, end);
            in.erase(0, end + 4);
            ++mRequests;
            Reply r = mScript(request);
            if (r.silent) continue;
            if (r.dripMs > 0) {
                drip(fd, r);
                break;
            }
            send(fd, r.bytes.data(), r.bytes.size(), MSG_NOSIGNAL);
            if (r.reset) {
                linger l{1, 0};
                setsockopt(fd, SOL_SOCKET, SO_LINGER, &l, sizeof l);
            }
            if (r.reset || r.close) break;
        }
        close(fd);
    }

    // Sends r's headers, then its body a byte at a time, until the peer leaves (at most 30 s).
    void drip(int fd, const Reply& r) {
        const size_t body = r.bytes.find("\r\n\r\n") + 4;
        if (send(fd, r.bytes.data(), body, MSG_NOSIGNAL) < 0) return;
        for (size_t i = body; i < r.bytes.size() && !mStop && (i - body) * r.dripMs < 30000; ++i) {
            std::this_thread::sleep_for(std::chrono::milliseconds(r.dripMs));
            if (send(fd, r.bytes.data() + i, 1, MSG_NOSIGNAL) < 0) return;
        }
    }

    std::function<Reply(const std::string&)> mScript;
    int mListen = -1;
    uint16_t mPort = 0;
    std::atomic<bool> mStop{false};
    std::atomic<int> mRequests{0}, mConnections{0};
    std::thread mThread;
};

std::string payload(size_t n) {
    std::string s(n, '\0');
    for (size_t i = 0; i < n; ++i) s[i] = char('a' + i % 26);
    return s;
}

std::string response206(std::string_view contentRange, size_t contentLength, std::string body) {
    return "HTTP/1.1 206 Partial Content\r\nContent-Range: " + std::string(contentRange) +
           "\r\nContent-Length: " + std::to_string(contentLength) + "\r\n\r\n" + body;
}

HttpOptions quickOptions() {
    HttpOptions o;
    o.connectTimeoutS = 1.0;
    o.readTimeoutS = 0.3;
    o.maxAttempts = 3;
    o.retryBackoffS = 0.01;
    return o;
}

FetchRequest rangeRequest(uint64_t id = 1) {
    return {id, "textures/t00001.ptm", ByteRange{0, 99}, 1000};
}

struct HostileCase {
    const char* name;
    Reply reply;
    const char* reason;  // expected in the failure message
    int requests;        // the server sees this many tries
};

TEST(HttpFetchHostile, EveryWrongAnswerFailsWithItsReason) {
    const std::string body = payload(100);
    const std::vector<HostileCase> cases = {
        {"wrong length",
         {response206("bytes 0-99/1000", 50, body.substr(0, 50))},
         "Content-Length 50, the range holds 100",
         1},
        {"wrong range", {response206("bytes 1-100/1000", 100, body)}, "differs from", 1},
        {"no range",
         {"HTTP/1.1 206 Partial Content\r\nContent-Length: 100\r\n\r\n" + body},
         "206 without Content-Range",
         1},
        {"200 for a range",
         {"HTTP/1.1 200 OK\r\nContent-Length: 100\r\n\r\n" + body},
         "status 200 (expected 206)",
         1},
        {"longer body",
         {response206("bytes 0-99/1000", 100, body + "trailing bytes")},
         "past the declared end",
         1},
        {"404", {"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\n\r\n"}, "status 404", 1},
        {"500", {"HTTP/1.1 500 Oops\r\nContent-Length: 0\r\n\r\n"}, "status 500", 3},
        {"silent", {"", true}, "no answer within 0.3 s", 3},
        {"reset mid-body",
         {response206("bytes 0-99/1000", 100, body.substr(0, 30)), false, true},
         "reading the body after 30 bytes",
         3},
        {"garbage", {"SSH-2.0-OpenSSH\r\n\r\n"}, "reading the headers", 3},
        // A byte every 0.1 s renews the 0.3 s read timeout for ever; the rate check ends it.
        {"drip",
         {response206("bytes 0-99/1000", 100, body), false, false, false, 100},
         "body slower than 1024 bytes/s for 0.3 s",
         3},
        {"gzip",
         {"HTTP/1.1 206 Partial Content\r\nContent-Range: bytes 0-99/1000\r\n"
          "Content-Encoding: gzip\r\nContent-Length: 100\r\n\r\n" +
          body},
         "Content-Encoding 'gzip'",
         1},
    };
    for (const HostileCase& c : cases) {
        SCOPED_TRACE(c.name);
        RawServer server([&](const std::string&) { return c.reply; });
        auto f = openHttpFetcher(server.url(), quickOptions());
        ASSERT_TRUE(f.isOk());
        FetchCompletion done = fetchOne(**f, rangeRequest(7));
        EXPECT_EQ(done.id, 7u);
        ASSERT_FALSE(done.status.isOk());
        const std::string& m = done.status.message();
        EXPECT_NE(m.find("textures/t00001.ptm bytes 0-99"), std::string::npos) << m;
        EXPECT_NE(m.find(c.reason), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
        EXPECT_TRUE(done.bytes.empty());
        EXPECT_EQ(server.requests(), c.requests) << m;
        EXPECT_EQ((*f)->pending(), 0u);
    }
}

TEST(HttpFetchHostile, DeclaredLengthAboveMaxBytesFailsBeforeTheBody) {
    // A whole-file request accepting 1000 bytes; the server declares a terabyte.
    RawServer server([](const std::string&) {
        return Reply{"HTTP/1.1 200 OK\r\nContent-Length: 1000000000000\r\n\r\nxxxx"};
    });
    auto f = openHttpFetcher(server.url(), quickOptions());
    ASSERT_TRUE(f.isOk());
    FetchCompletion done = fetchOne(**f, {3, "root.json", std::nullopt, 1000});
    ASSERT_FALSE(done.status.isOk());
    EXPECT_NE(done.status.message().find("root.json"), std::string::npos);
    EXPECT_EQ(done.status.code(), ErrorCode::kOutOfRange) << done.status.message();
    // A chunked body longer than maxBytes is cut off at the limit too.
    RawServer chunked([](const std::string&) {
        return Reply{"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n7d0\r\n" +
                     payload(2000) + "\r\n0\r\n\r\n"};
    });
    auto g = openHttpFetcher(chunked.url(), quickOptions());
    FetchCompletion cut = fetchOne(**g, {4, "root.json", std::nullopt, 1000});
    ASSERT_FALSE(cut.status.isOk());
    EXPECT_NE(cut.status.message().find("body longer than the 1000 bytes"), std::string::npos)
        << cut.status.message();
}

TEST(HttpFetchHostile, GoodAnswersShareOneConnectionInOrder) {
    const std::string body = payload(100);
    RawServer server([&](const std::string& request) {
        EXPECT_NE(request.find("GET /db/textures/t00001.ptm HTTP/1.1"), std::string::npos);
        EXPECT_NE(request.find("Range: bytes=0-99"), std::string::npos);
        return Reply{response206("bytes 0-99/1000", 100, body)};
    });
    auto f = openHttpFetcher(server.url(), quickOptions());
    ASSERT_TRUE(f.isOk());
    for (uint64_t id = 1; id <= 5; ++id) (*f)->submit(rangeRequest(id), double(id));
    EXPECT_LE((*f)->pending(), 5u);
    auto done = waitFor(**f, 5);
    ASSERT_EQ(done.size(), 5u);
    for (uint64_t i = 0; i < 5; ++i) {
        EXPECT_EQ(done[i].id, i + 1);
        ASSERT_TRUE(done[i].status.isOk()) << done[i].status.message();
        EXPECT_EQ(std::string(done[i].bytes.begin(), done[i].bytes.end()), body);
        EXPECT_GE(done[i].finishedAtS, done[i].submittedAtS);
    }
    EXPECT_EQ(server.connections(), 1);
    // A path outside the format's names fails without reaching the server.
    FetchCompletion bad = fetchOne(**f, {9, "../etc/passwd", std::nullopt, 100});
    EXPECT_FALSE(bad.status.isOk());
    EXPECT_EQ(server.requests(), 5);
}

TEST(HttpFetchHostile, EveryTruncatedPrefixOfAGoodAnswerFails) {
    const std::string good = response206("bytes 0-99/1000", 100, payload(100));
    HttpOptions once = quickOptions();
    once.maxAttempts = 1;
    // One server sends the n-th connection a prefix of n bytes, then an orderly close (FIN);
    // one fetcher reconnects for each request.
    std::atomic<size_t> next{0};
    RawServer server([&](const std::string&) {
        return Reply{good.substr(0, next++), false, false, true};
    });
    auto prefixes = openHttpFetcher(server.url(), once);
    ASSERT_TRUE(prefixes.isOk());
    for (size_t n = 0; n < good.size(); ++n) {
        FetchCompletion done = fetchOne(**prefixes, rangeRequest(n));
        EXPECT_FALSE(done.status.isOk()) << n;
        EXPECT_TRUE(done.bytes.empty()) << n;
    }
    EXPECT_EQ(server.connections(), int(good.size()));
    RawServer whole([&](const std::string&) { return Reply{good, false, false, true}; });
    auto f = openHttpFetcher(whole.url(), once);
    EXPECT_TRUE(fetchOne(**f, rangeRequest()).status.isOk());
}

TEST(HttpFetchHostile, RangesBeyondMaxBytesAreRefusedBeforeSending) {
    RawServer server([](const std::string&) { return Reply{}; });
    auto f = openHttpFetcher(server.url(), quickOptions());
    ASSERT_TRUE(f.isOk());
    const uint64_t kLast = ~uint64_t(0);
    for (ByteRange r : {ByteRange{0, kLast}, ByteRange{10, 9}, ByteRange{0, 1000}}) {
        FetchCompletion done = fetchOne(**f, {1, "root.json", r, 1000});
        EXPECT_EQ(done.status.code(), ErrorCode::kInvalidArgument) << done.status.message();
    }
    EXPECT_EQ(server.requests(), 0);
}

TEST(HttpFetchHostile, NoServerFailsAfterBoundedTries) {
    // Port 1 (tcpmux) is privileged and unused: the connection is refused.
    auto f = openHttpFetcher("http://127.0.0.1:1/db", quickOptions());
    ASSERT_TRUE(f.isOk());
    FetchCompletion done = fetchOne(**f, rangeRequest());
    ASSERT_FALSE(done.status.isOk());
    EXPECT_NE(done.status.message().find("connecting to 127.0.0.1:1"), std::string::npos)
        << done.status.message();
    EXPECT_NE(done.status.message().find("(3 tries)"), std::string::npos);
}

// nginx (Debian nginx-light) over a built database: the configuration docs/stream-http.md shows,
// serving `db` at /db/ and, throttled to `limitRate` bytes/s, at /slow/.
class Nginx : public plx::testing::NginxProcess {
public:
    Nginx(const fs::path& tmp, const fs::path& db, uint64_t limitRate)
        : Nginx(tmp, db, limitRate, plx::testing::freeLoopbackPort()) {}

private:
    Nginx(const fs::path& tmp, const fs::path& db, uint64_t limitRate, uint16_t port)
        : NginxProcess(tmp, nginxConfig(tmp, db, limitRate, port), port) {}

    static std::string nginxConfig(const fs::path& tmp, const fs::path& db, uint64_t limitRate,
                                   uint16_t port) {
        const std::string d = db.string();
        std::ostringstream c;
        c << prelude(tmp) << "    types { application/json json; model/gltf-binary glb; }\n"
          << "    default_type application/octet-stream;\n"
          << "    server {\n        listen 127.0.0.1:" << port << ";\n"
          << "        location /db/ { alias " << d << "/; }\n"
          << "        location /slow/ { alias " << d << "/; limit_rate " << limitRate << "; }\n"
          << "    }\n}\n";
        return c.str();
    }
};

struct Expected {
    std::string path;
    std::optional<ByteRange> range;
    std::vector<uint8_t> bytes;
};

// Every file of the database whole, and every PTM file's header and level groups by Range
// (the PTM level index; docs/ptm-format.md).
std::vector<Expected> everyFileAndGroup(const fs::path& db) {
    std::vector<Expected> out;
    for (const auto& e : fs::recursive_directory_iterator(db)) {
        if (!e.is_regular_file()) continue;
        const std::string rel = fs::relative(e.path(), db).generic_string();
        std::vector<uint8_t> bytes = fileBytes(e.path());
        out.push_back({rel, std::nullopt, bytes});
        if (e.path().extension() != ".ptm") continue;
        auto header = ptm::parseHeader(bytes);
        EXPECT_TRUE(header.isOk()) << rel;
        if (!header) continue;
        auto slice = [&](uint64_t first, uint64_t size) {
            std::vector<uint8_t> b(bytes.begin() + first, bytes.begin() + first + size);
            out.push_back({rel, ByteRange{first, first + size - 1}, std::move(b)});
        };
        slice(0, header->headerBytes());
        for (int k = 0; k < header->levelCount; ++k) {
            ptm::ByteRange g = ptm::levelByteRange(*header, k);
            slice(g.offset, g.size);
        }
    }
    return out;
}

// Writes a small museum:2 database (two samples, 16-pixel faces) into `db`.
Status buildMuseum2(const fs::path& db) {
    scene::Scene museum = scene::generateMuseum(2).value();
    Cells cells = makeCells(museum).value();
    VisibilityConfig sampling;
    sampling.samples = 2;
    sampling.faceSize = 16;
    auto vis = computeVisibility(museum, cells, sampling, 0, uint32_t(cells.boxes.size() - 1));
    if (!vis) return vis.status();
    return writeDatabase(museum, cells, *vis, sampling, "museum:2", db.string()).status();
}

TEST(HttpFetchNginx, RangesMatchTheFilesAndLimitRateThrottles) {
    if (!fs::exists(Nginx::kNginx)) {
        GTEST_SKIP() << "no " << Nginx::kNginx << " (Debian nginx-light): HTTP test skipped";
    }
    const fs::path tmp = freshTempDir("http_nginx"), db = tmp / "db";
    Status built = buildMuseum2(db);
    ASSERT_TRUE(built.isOk()) << built.toString();

    const std::vector<Expected> expected = everyFileAndGroup(db);
    uint64_t largest = 0;
    std::string largestPath;
    for (const Expected& e : expected) {
        if (!e.range && e.bytes.size() > largest) largest = e.bytes.size(), largestPath = e.path;
    }
    // nginx lets one second's worth through at once (limit = rate * (t + 1)), so the rate is
    // set for the largest file to take about 3 s: at least 2 s by the algorithm.
    const uint64_t limitRate = std::max<uint64_t>(largest / 3, 1);

    Nginx nginx(tmp, db, limitRate);
    ASSERT_TRUE(nginx.ready()) << "nginx did not start: " << nginx.errorLog();

    auto f = openHttpFetcher(nginx.url("db"));
    ASSERT_TRUE(f.isOk()) << f.status().toString();
    for (size_t i = 0; i < expected.size(); ++i) {
        (*f)->submit({i, expected[i].path, expected[i].range, uint64_t(64) << 20}, 0.0);
    }
    auto done = waitFor(**f, expected.size());
    ASSERT_EQ(done.size(), expected.size());
    for (size_t i = 0; i < done.size(); ++i) {
        SCOPED_TRACE(expected[i].path);
        EXPECT_EQ(done[i].id, i);  // FIFO
        ASSERT_TRUE(done[i].status.isOk()) << done[i].status.message();
        EXPECT_TRUE(done[i].bytes == expected[i].bytes);
    }
    FetchCompletion missing = fetchOne(**f, {99, "textures/t99999.ptm", ByteRange{0, 9}, 100});
    EXPECT_EQ(missing.status.code(), ErrorCode::kNotFound) << missing.status.message();
    FetchCompletion past = fetchOne(**f, {100, largestPath, ByteRange{largest, largest + 9}, 100});
    EXPECT_NE(past.status.message().find("status 416"), std::string::npos) << past.status.message();

    auto slow = openHttpFetcher(nginx.url("slow"));
    ASSERT_TRUE(slow.isOk());
    const auto start = Clock::now();
    FetchCompletion throttled = fetchOne(**slow, {1, largestPath, std::nullopt, largest});
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    ASSERT_TRUE(throttled.status.isOk()) << throttled.status.message();
    EXPECT_EQ(throttled.bytes.size(), largest);
    // A lower bound only (a loaded machine is slower, never faster): N / rate - 1 s, with margin.
    const double atLeast = 0.8 * (double(largest) / double(limitRate) - 1.0);
    EXPECT_GE(seconds, atLeast) << largest << " bytes at limit_rate " << limitRate;
    fs::remove_all(tmp);
}

// The streaming client over HTTP against nginx, as over the simulator: a static viewpoint with
// a budget that holds everything reaches full quality with no failed request, under the cap.
TEST(HttpFetchNginx, StreamClientReachesFullQualityOverNginx) {
    if (!fs::exists(Nginx::kNginx)) {
        GTEST_SKIP() << "no " << Nginx::kNginx << " (Debian nginx-light): HTTP test skipped";
    }
    const fs::path tmp = freshTempDir("http_client"), db = tmp / "db";
    Status built = buildMuseum2(db);
    ASSERT_TRUE(built.isOk()) << built.toString();
    Nginx nginx(tmp, db, 1 << 20);
    ASSERT_TRUE(nginx.ready()) << "nginx did not start: " << nginx.errorLog();
    auto fetcher = openFetcher(nginx.url("db"), {});
    ASSERT_TRUE(fetcher.isOk()) << fetcher.status().toString();
    EXPECT_TRUE((*fetcher)->realTime());

    auto root = parseRoot(fileBytes(db / "root.json")).value();
    CameraDesc d;
    d.eyePos = root.viewpoints[0].eyePos, d.targetPos = root.viewpoints[0].targetPos;
    d.width = 64, d.height = 48;
    const Camera camera = Camera::create(d).value();
    ClientConfig config;
    config.budgetBytes = config.staticBudgetBytes = uint64_t(256) << 20;
    StreamClient client(fetcher->get(), config);
    FrameReport last;
    const auto start = Clock::now();
    // Bounded: at most 20 s of wall time (the museum:2 database is ~0.3 MB over loopback).
    for (int f = 0; f < 4000 && last.quality < 1.0; ++f) {
        const double now = std::chrono::duration<double>(Clock::now() - start).count();
        if (now > 20.0) break;
        last = client.frame(camera, now);
        ASSERT_LE(last.residentBytes, last.budgetBytes);
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    EXPECT_DOUBLE_EQ(last.quality, 1.0);
    EXPECT_EQ(client.failedRequests(), 0u) << (client.log().empty() ? "" : client.log()[0]);
    fs::remove_all(tmp);
}

// Submits every request of `requests` in turn, `rounds` times, and reports requests/s and MB/s
// (one connection, FIFO: what the streaming client sees).
void measure(const char* label, Fetcher& f, const std::vector<Expected>& requests, int rounds) {
    uint64_t bytes = 0, id = 0;
    const auto start = Clock::now();
    for (int round = 0; round < rounds; ++round) {
        for (const Expected& e : requests) f.submit({id++, e.path, e.range, uint64_t(64) << 20}, 0);
        for (const FetchCompletion& c : waitFor(f, requests.size())) {
            EXPECT_TRUE(c.status.isOk()) << c.status.message();
            bytes += c.bytes.size();
        }
    }
    const double s = std::chrono::duration<double>(Clock::now() - start).count();
    std::printf("%s: %llu requests, %.1f KB each, %.3f s: %.0f requests/s, %.1f KB/s\n", label,
                (unsigned long long)id, double(bytes) / double(id) / 1e3, s, double(id) / s,
                double(bytes) / s / 1e3);
}

// Loopback figures for docs/stream-results.md; runs only with PLX_STREAM_HTTP_MEASURE=1
// (timings are measurements, not pass/fail).
TEST(HttpFetchNginx, MeasureLoopback) {
    if (!std::getenv("PLX_STREAM_HTTP_MEASURE")) GTEST_SKIP() << "set PLX_STREAM_HTTP_MEASURE=1";
    if (!fs::exists(Nginx::kNginx)) GTEST_SKIP() << "no " << Nginx::kNginx;
    const fs::path tmp = freshTempDir("http_measure"), db = tmp / "db";
    ASSERT_TRUE(buildMuseum2(db).isOk());
    std::vector<Expected> groups, wholes;
    for (Expected& e : everyFileAndGroup(db)) (e.range ? groups : wholes).push_back(std::move(e));
    const uint64_t limitRate = 64 * 1024;
    Nginx nginx(tmp, db, limitRate);
    ASSERT_TRUE(nginx.ready()) << nginx.errorLog();
    auto f = openHttpFetcher(nginx.url("db"));
    ASSERT_TRUE(f.isOk());
    measure("level groups, unthrottled", **f, groups, 20);
    measure("whole files, unthrottled", **f, wholes, 20);
    auto slow = openHttpFetcher(nginx.url("slow"));
    ASSERT_TRUE(slow.isOk());
    std::printf("limit_rate %llu bytes/s:\n", (unsigned long long)limitRate);
    measure("level groups, limit_rate", **slow, groups, 1);
    std::vector<Expected> largest = {*std::max_element(
        wholes.begin(), wholes.end(),
        [](const Expected& a, const Expected& b) { return a.bytes.size() < b.bytes.size(); })};
    measure("largest file, limit_rate", **slow, largest, 1);
    fs::remove_all(tmp);
}

}  // namespace
}  // namespace plx::stream
