// Remote sessions beyond one machine (issue 26, item 8): nginx (Debian nginx-light) in front of
// two `parallax serve` processes, the configuration of docs/remote-proxy.md, and warping
// clients (libs/remote's Client) connecting through it. Each client must receive reference sets
// through the proxy, and session affinity must hold: a client that reconnects with the same
// session key lands on the same server. Which server served a connection is read from nginx's
// access log ($upstream_addr per session key) and cross-checked with each server's own session
// count (`parallax serve --json` prints it when stopped). Everything binds to 127.0.0.1 on free
// ports, every wait is bounded, and the test stops every process it started.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <plx_test/nginx.h>
#include <nlohmann/json.hpp>

#include <plx/remote/client.h>
#include <plx/scene/generators.h>
#include <plx/warp/reference.h>

#include "serve_process.h"

namespace plx::testing {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// Small faces and one render thread each: the two servers share this machine with the test.
constexpr const char* kServeArgs = "office:1 --face-size 32 --threads 1";
constexpr size_t kClientsAtOnce = 4;

fs::path freshDir(const std::string& name) {
    fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
        if (!line.empty()) out.push_back(line);
    return out;
}

// docs/remote-proxy.md's configuration, with the test's ports and paths, the affinity directive
// under test, and an access log line per session: its key, the upstream that served it, the
// status (101 for a WebSocket upgrade).
std::string proxyConfig(const fs::path& tmp, uint16_t port, const std::vector<int>& upstreams,
                        const std::string& affinity) {
    std::ostringstream c;
    c << NginxProcess::prelude(tmp)
      << "    log_format affinity '$arg_session $upstream_addr $status';\n"
      << "    access_log " << tmp.string() << "/sessions.log affinity;\n"
      << "    map $http_upgrade $connection_upgrade { default upgrade; '' close; }\n"
      << "    upstream parallax {\n        " << affinity << ";\n";
    for (int p : upstreams) c << "        server 127.0.0.1:" << p << ";\n";
    c << "    }\n    server {\n        listen 127.0.0.1:" << port << ";\n"
      << "        location / {\n"
      << "            proxy_pass http://parallax;\n"
      << "            proxy_http_version 1.1;\n"
      << "            proxy_set_header Upgrade $http_upgrade;\n"
      << "            proxy_set_header Connection $connection_upgrade;\n"
      << "            proxy_set_header Host $host;\n"
      << "            proxy_read_timeout 60s;\n"
      << "            proxy_send_timeout 60s;\n"
      << "        }\n    }\n}\n";
    return c.str();
}

// One session through the proxy with key `session`: connects, sends a pose, waits (at most 20 s)
// for a reference set, checks it, says Bye. Returns whether a well-formed set arrived.
bool sessionThroughProxy(uint16_t proxyPort, const std::string& session,
                         const scene::Scene& scene) {
    remote::ClientConfig c;
    c.port = proxyPort;
    c.path = "/?session=" + session;
    c.faceSize = 32;
    c.backoffMinMs = 50.0;
    c.backoffMaxMs = 400.0;
    auto client = remote::Client::create(c);
    if (!client) return false;
    remote::PoseMessage pose;
    pose.timestampUs = remote::clientNowUs();
    pose.pose = warp::poseAt(scene.viewpoints.front());
    (*client)->setPose(pose);
    const bool arrived = (*client)->waitForFirst(20000.0);
    std::shared_ptr<const remote::ReceivedSet> set = (*client)->newest();
    (*client)->stop();
    return arrived && set && set->set.views.size() == 4 &&
           set->set.views.front().color.width() == 32;
}

struct Served {
    std::map<std::string, std::set<std::string>> upstreamsOf;  // session key -> upstreams
    std::map<std::string, int> connectionsTo;                  // upstream -> connections
    int upgrades = 0;
};

// Reads the affinity log once it has `expected` lines (waits at most 10 s: nginx writes a
// WebSocket's line when the connection closes).
Served readSessionsLog(const fs::path& tmp, size_t expected) {
    std::vector<std::string> l;
    for (auto end = Clock::now() + 10s; Clock::now() < end; std::this_thread::sleep_for(20ms)) {
        l = lines(NginxProcess::fileText(tmp / "sessions.log"));
        if (l.size() >= expected) break;
    }
    Served s;
    for (const std::string& line : l) {
        std::istringstream in(line);
        std::string key, upstream, status;
        in >> key >> upstream >> status;
        s.upstreamsOf[key].insert(upstream);
        ++s.connectionsTo[upstream];
        s.upgrades += status == "101";
    }
    return s;
}

// Starts two servers and nginx with `affinity`, runs `keys` sessions, then each again (the
// reconnection), and returns what the log and the servers say.
struct ProxyRun {
    Served served;
    std::vector<int> ports;
    std::vector<int64_t> sessionsTotal;
    int setsReceived = 0;
};

void runThroughProxy(const std::string& name, const std::string& affinity,
                     const std::vector<std::string>& keys, ProxyRun* run) {
    const fs::path tmp = freshDir(name);
    ServeProcess a(kServeArgs), b(kServeArgs);
    run->ports = {a.port(), b.port()};
    ASSERT_GT(run->ports[0], 0);
    ASSERT_GT(run->ports[1], 0);
    const uint16_t proxyPort = freeLoopbackPort();
    NginxProcess nginx(tmp, proxyConfig(tmp, proxyPort, run->ports, affinity), proxyPort);
    ASSERT_TRUE(nginx.ready()) << "nginx did not start: " << nginx.errorLog();

    const scene::Scene scene = *scene::generateFromSpec("office:1");
    // Every key once, kClientsAtOnce clients at a time, then every key again: a reconnection.
    for (int round = 0; round < 2; ++round)
        for (size_t first = 0; first < keys.size(); first += kClientsAtOnce) {
            const size_t end = std::min(keys.size(), first + kClientsAtOnce);
            std::vector<std::thread> threads;
            std::vector<char> ok(keys.size(), 0);
            for (size_t i = first; i < end; ++i)
                threads.emplace_back(
                    [&, i] { ok[i] = sessionThroughProxy(proxyPort, keys[i], scene); });
            for (std::thread& t : threads) t.join();
            for (size_t i = first; i < end; ++i) {
                EXPECT_TRUE(ok[i]) << "session " << keys[i] << " round " << round
                                   << " got no reference set; nginx: " << nginx.errorLog();
                run->setsReceived += ok[i];
            }
        }
    run->served = readSessionsLog(tmp, 2 * keys.size());
    for (ServeProcess* s : {&a, &b}) {
        nlohmann::json stopped = s->stop().first;
        if (!stopped.is_object()) stopped = nlohmann::json::object();
        run->sessionsTotal.push_back(stopped.value("sessions_total", int64_t(-1)));
    }
}

// The servers' own counts agree with the proxy's log: every connection the log gives a server
// was a session there.
void expectCountsAgree(const ProxyRun& run, size_t connections) {
    EXPECT_EQ(run.served.upgrades, int(connections));
    for (size_t i = 0; i < run.ports.size(); ++i) {
        const std::string upstream = "127.0.0.1:" + std::to_string(run.ports[i]);
        auto it = run.served.connectionsTo.find(upstream);
        const int logged = it == run.served.connectionsTo.end() ? 0 : it->second;
        EXPECT_EQ(run.sessionsTotal[i], logged) << upstream;
    }
}

// `hash $arg_session consistent`: sessions spread over both servers, and each key's second
// connection lands where its first did. The hash ring depends on the servers' addresses (free
// ports, new each run), so which key goes where changes from run to run; with 16 keys the chance
// that all land on one server is about 2 * 2^-16.
TEST(RemoteProxy, SessionKeyAffinitySpreadsSessionsAndKeepsReconnections) {
    if (!NginxProcess::available())
        GTEST_SKIP() << "no " << NginxProcess::kNginx
                     << " (Debian nginx-light): proxy test skipped";
    std::vector<std::string> keys;
    for (int i = 0; i < 16; ++i) keys.push_back("viewer" + std::to_string(i));
    ProxyRun run;
    runThroughProxy("remote_proxy_hash", "hash $arg_session consistent", keys, &run);
    if (HasFatalFailure()) return;
    EXPECT_EQ(run.setsReceived, int(2 * keys.size()));
    expectCountsAgree(run, 2 * keys.size());
    ASSERT_EQ(run.served.upstreamsOf.size(), keys.size());
    for (const auto& [key, upstreams] : run.served.upstreamsOf)
        EXPECT_EQ(upstreams.size(), 1u) << key << " reconnected to another server";
    EXPECT_EQ(run.served.connectionsTo.size(), 2u) << "one server got every session";
}

// `ip_hash`, the documented default: every client here is 127.0.0.1, so every session and every
// reconnection goes to one server.
TEST(RemoteProxy, IpHashKeepsEveryClientOfOneAddressOnOneServer) {
    if (!NginxProcess::available())
        GTEST_SKIP() << "no " << NginxProcess::kNginx
                     << " (Debian nginx-light): proxy test skipped";
    const std::vector<std::string> keys = {"one", "two", "three"};
    ProxyRun run;
    runThroughProxy("remote_proxy_iphash", "ip_hash", keys, &run);
    if (HasFatalFailure()) return;
    EXPECT_EQ(run.setsReceived, int(2 * keys.size()));
    expectCountsAgree(run, 2 * keys.size());
    EXPECT_EQ(run.served.connectionsTo.size(), 1u);
}

}  // namespace
}  // namespace plx::testing
