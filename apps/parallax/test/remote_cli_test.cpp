// parallax serve and parallax client run as a user would, as separate processes over loopback:
// the JSON fields and session lines, a token refused, SIGTERM stopping the server, a server
// outliving its stdout's reader, one-line errors for bad arguments. Servers bind 127.0.0.1 on free
// ports (--port 0) and stop by themselves.

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <plx/remote/protocol.h>
#include <plx/remote/transport.h>
#include <plx_test/loopback.h>

#include "cli_runner.h"
#include "serve_process.h"

namespace {

using namespace plx::testing;

TEST(RemoteCli, ServeAndClientEndToEnd) {
    ServeProcess server("office:1 --face-size 64");
    ASSERT_GT(server.port(), 0);
    EXPECT_EQ(server.listening["bind"], "127.0.0.1");  // loopback unless --bind says otherwise
    fs::path out = scratchDir("remote_cli") / "walk";
    fs::remove_all(out);
    RunResult r = runParallax("client " + server.url() +
                              " --walk 30 --scene office:1 --size 160x120 --every 10 --out " +
                              out.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    for (const char* key : {"frames", "client_fps", "warp_ms_median", "reference_age_ms_median",
                            "references_received", "bytes_per_reference", "psnr_db_median"})
        EXPECT_TRUE(doc.contains(key)) << key;
    EXPECT_EQ(doc["frames"], 30);
    EXPECT_GE(doc["references_received"].get<int>(), 1);
    EXPECT_GT(doc["bytes_per_reference"].get<double>(), 0.0);
    EXPECT_LT(doc["bytes_per_reference"].get<double>(),
              doc["raw_bytes_per_reference"].get<double>());
    EXPECT_GT(doc["psnr_db_median"].get<double>(), 15.0);
    EXPECT_EQ(doc["frames_written"], 3);
    EXPECT_TRUE(fs::exists(out / "frame-00010.png"));
    EXPECT_TRUE(fs::exists(out / "stats.csv"));
    auto [stopped, code] = server.stop();
    EXPECT_EQ(code, 0);
    ASSERT_TRUE(stopped.is_object());
    EXPECT_EQ(stopped["event"], "stopped");
    EXPECT_GE(stopped["sets_sent"].get<int>(), 1);
    EXPECT_GT(stopped["render_ms_mean"].get<double>(), 0.0);
    // The session log: the client came, and left saying goodbye with every set sent.
    ASSERT_EQ(server.sessionLines.size(), 2u);
    const nlohmann::json &came = server.sessionLines[0], &left = server.sessionLines[1];
    EXPECT_EQ(came["event"], "session_accepted");
    EXPECT_EQ(came["session"], 1);
    EXPECT_EQ(came["address"], "127.0.0.1");
    EXPECT_GT(came["face_size"].get<int>(), 0);
    EXPECT_EQ(left["event"], "session_ended");
    EXPECT_EQ(left["session"], 1);
    EXPECT_EQ(left["reason"], "client said goodbye");
    EXPECT_EQ(left["sets_sent"], stopped["sets_sent"]);
    EXPECT_EQ(left["bytes_sent"], stopped["bytes_sent"]);
    EXPECT_GT(left["duration_s"].get<double>(), 0.0);
}

TEST(RemoteCli, PathFileAndStereoWithoutScene) {
    ServeProcess server("office:1 --face-size 32 --refs cube6");
    ASSERT_GT(server.port(), 0);
    fs::path path = scratchDir("remote_cli") / "path.json";
    writeFile(path, R"({"poses": [{"eye": [1,1.6,1], "target": [4,1.2,5]},
                                  {"eye": [1.05,1.6,1.05], "target": [4,1.2,5]}]})");
    // From another loopback address (RemoteSession.SessionsFromOneAddressAreLimited shows the
    // server sees it).
    RunResult r =
        runParallax("client " + server.url() + " --path " + path.string() +
                    " --frames 6 --stereo --size 64x48 --source-address 127.0.0.2 --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["frames"], 6);
    EXPECT_TRUE(doc["stereo"].get<bool>());
    EXPECT_FALSE(doc.contains("psnr_db_median"));
    // The loop shows 60 frames a second at most, however few it plays: its time runs to the end
    // of the last frame's interval (to the end of the last warp, 6 frames read as about 70 a
    // second).
    EXPECT_LE(doc["client_fps"].get<double>(), 60.0 * 1.001);
    EXPECT_GE(doc["seconds"].get<double>(), 6.0 / 60.0);
}

TEST(RemoteCli, ClientMemoryEstimateHoldsItsPeak) {
    if (kUnderAddressSanitizer) GTEST_SKIP() << "no release peak under AddressSanitizer";
    ServeProcess server("office:1 --face-size 64");
    ASSERT_GT(server.port(), 0);
    fs::path out = scratchDir("remote_cli") / "memory";
    fs::remove_all(out);
    fs::path path = scratchDir("remote_cli") / "memory_path.json";
    writeFile(path, R"({"poses": [{"eye": [1,1.6,1], "target": [4,1.2,5]}]})");
    // The least and the most the client keeps per display pixel (clientBytesPerPixel).
    for (const std::string& args :
         {" --path " + path.string(),
          " --walk 20 --scene office:1 --stereo --every 5 --out " + out.string()}) {
        const std::string command =
            "client " + server.url() + args + " --frames 20 --size 1536x1152 --json";
        RunResult r = runParallax(command);
        ASSERT_EQ(r.exitCode, 0) << command << ": " << r.err;
        expectEstimateHoldsPeak(r.out, command);
    }
}

TEST(RemoteCli, ServeMemoryEstimateHoldsItsPeak) {
    if (kUnderAddressSanitizer) GTEST_SKIP() << "no release peak under AddressSanitizer";
    fs::path path = scratchDir("remote_cli") / "serve_memory_path.json";
    writeFile(path, R"({"poses": [{"eye": [1,1.6,1], "target": [4,1.2,5]}]})");
    // The client asks faces of 1774 pixels for 1024 rows; both servers render their largest.
    for (const std::string refs : {"cube4", "cube6"}) {
        ServeProcess server("office:1 --face-size 1536 --refs " + refs);
        ASSERT_GT(server.port(), 0);
        RunResult r = runParallax("client " + server.url() + " --path " + path.string() +
                                  " --refs " + refs + " --frames 3 --size 1024x1024");
        ASSERT_EQ(r.exitCode, 0) << r.err;
        auto [stopped, code] = server.stop();
        ASSERT_EQ(code, 0);
        expectEstimateHoldsPeak(stopped.dump(), "serve --refs " + refs);
    }
    // Refused before it listens: 0.8 GiB for cube6 faces of 4096 under 512 MiB of address space.
    expectOneLineError(
        runParallax("serve office:1 --refs cube6 --face-size 4096 --port 0 --seconds 1",
                    "ulimit -v 524288; "),
        "serve --refs cube6 --face-size 4096 --max-sessions 16 --max-queued 256 needs about");
    // Sets of 48 MiB raw (cube6, faces of 1024): 64 sessions may queue 1 GiB, more than 1 GiB of
    // address space leaves; with --max-queued 64, 64 MiB and one set.
    const std::string limit = "ulimit -v 1048576; ";
    const std::string many = "serve office:1 --refs cube6 --face-size 1024 --max-sessions 64 ";
    expectOneLineError(runParallax(many + "--max-queued 1024 --port 0 --seconds 0.5", limit),
                       "--max-sessions 64 --max-queued 1024 needs about");
    RunResult bounded = runParallax(many + "--max-queued 64 --port 0 --seconds 0.5", limit);
    EXPECT_EQ(bounded.exitCode, 0) << bounded.err;
}

// A client that plays one pose at 64x48 against `url`.
RunResult runOnePoseClient(const std::string& url) {
    fs::path path = scratchDir("remote_cli") / "one_pose.json";
    writeFile(path, R"([{"eye": [1,1.6,1], "target": [4,1.2,5]}])");
    return runParallax("client " + url + " --path " + path.string() + " --size 64x48 --frames 3");
}

// More connections than the server has file descriptors: its accepts fail until some close. It
// waits between tries (it spun a core on them before) and serves again once they close.
TEST(RemoteCli, FailedAcceptsDoNotSpin) {
    // UBSan's dynamic type check tests memory through a pipe it opens on the spot; with no file
    // descriptor left it reports every object it has not checked before as having a bad vptr.
    if (kUnderAddressSanitizer) GTEST_SKIP() << "the sanitizers need file descriptors it takes";
    ServeProcess server("office:1 --face-size 32", {.openFilesSoft = 64, .openFilesHard = 64});
    ASSERT_GT(server.port(), 0);
    EXPECT_EQ(server.listening.value("open_files", 0), 64);  // the hard limit: it cannot raise it
    ASSERT_GE(server.cpuSeconds(), 0.0) << "no /proc/PID/stat to read the server's CPU time";
    std::vector<int> flood;
    for (int i = 0; i < 100; ++i)
        if (int fd = silentConnection(server.port()); fd >= 0) flood.push_back(fd);
    EXPECT_EQ(flood.size(), 100u);  // the kernel's backlog takes them all
    const double before = server.cpuSeconds();
    std::this_thread::sleep_for(std::chrono::seconds(2));
    EXPECT_LT(server.cpuSeconds() - before, 0.5) << "the server spun on failed accepts";
    for (int fd : flood) close(fd);
    EXPECT_EQ(runOnePoseClient(server.url()).exitCode, 0);
    auto [stopped, code] = server.stop();
    EXPECT_EQ(code, 0);
    EXPECT_GT(stopped.value("accept_failures", 0), 0);
}

// The same flood against --max-pending 16: the server drops the oldest silent connections as new
// ones come, never runs out of file descriptors, and serves a client while the flood still holds
// its sockets (without the limit, the client waits for the flood's handshake timeout, 5 s).
TEST(RemoteCli, ASilentFloodLeavesRoomForClients) {
    ServeProcess server("office:1 --face-size 32 --max-pending 16",
                        {.openFilesSoft = 64, .openFilesHard = 64});
    ASSERT_GT(server.port(), 0);
    std::vector<int> flood;
    for (int i = 0; i < 100; ++i)
        if (int fd = silentConnection(server.port()); fd >= 0) flood.push_back(fd);
    EXPECT_EQ(flood.size(), 100u);
    RunResult r = runOnePoseClient(server.url());
    EXPECT_EQ(r.exitCode, 0) << r.err;
    auto [stopped, code] = server.stop();
    EXPECT_EQ(code, 0);
    EXPECT_EQ(stopped.value("accept_failures", -1), 0);
    EXPECT_GE(stopped.value("pending_dropped", 0), 84);  // all but the newest 16 silent ones
    for (int fd : flood) close(fd);
}

// A soft limit on open files below what its sessions and pending connections need is raised (as
// far as the hard limit allows); one the hard limit keeps too low is a warning, an error with
// --strict.
TEST(RemoteCli, ServeRaisesItsOpenFilesLimit) {
    rlimit inherited{};
    ASSERT_EQ(getrlimit(RLIMIT_NOFILE, &inherited), 0);
    for (auto [sessions, needed] : {std::pair{16, 112}, std::pair{1024, 1120}}) {
        ServeProcess server("office:1 --face-size 32 --max-sessions " + std::to_string(sessions),
                            {.openFilesSoft = 64});
        ASSERT_GT(server.port(), 0);
        EXPECT_EQ(server.listening.value("open_files", 0),
                  std::min<uint64_t>(needed, inherited.rlim_max))
            << sessions << " sessions";
    }
    expectOneLineError(
        runParallax("--strict serve office:1 --port 0 --seconds 0.5", "ulimit -n 64; "),
        "64 open files allowed (ulimit -n); --max-sessions 16 and --max-pending 64 "
        "need about 112");
}

TEST(RemoteCli, WideServerAnnouncesTheFaceItServes) {
    // 16:9 views of 4096 rows would be 7282 wide; clients decode 4096: 2304 rows.
    ServeProcess server("office:1 --refs wide --face-size 4096");
    ASSERT_GT(server.port(), 0);
    EXPECT_EQ(server.listening.value("face_size", 0), 2304);
}

// A server whose stdout reader went away (`serve --json | head -1`) keeps serving: its session
// lines are dropped, not the process (SIGPIPE), and SIGTERM still stops it cleanly.
TEST(RemoteCli, ServeOutlivesItsStdoutReader) {
    ServeProcess server("office:1 --face-size 32");
    ASSERT_GT(server.port(), 0);
    server.closeReader();
    for (int i = 0; i < 2; ++i) {
        RunResult r = runParallax("client " + server.url() +
                                  " --walk 10 --scene office:1 --size 64x48 --json");
        EXPECT_EQ(r.exitCode, 0) << i << ": " << r.err;
    }
    EXPECT_EQ(server.stop().second, 0);
}

// A reader that stops reading after the listening line: once its pipe is full the session
// lines are dropped, not waited for (they are written on the I/O thread every session shares),
// so clients are still served; the stopped line, read again, counts the lines dropped.
TEST(RemoteCli, ServeOutlivesAReaderThatStopsReading) {
    ServeProcess server("office:1 --face-size 32 --token abc", {.pipeBytes = 4096});
    ASSERT_GT(server.port(), 0);
    // 100 refused hellos: about 8 KiB of session lines, twice the pipe's size.
    auto transport = std::move(plx::remote::Transport::create()).value();
    plx::remote::ClientHello hello;
    hello.token = "wrong";
    const std::vector<uint8_t> bytes = plx::remote::encodeMessage(hello).value();
    std::vector<std::future<void>> closed;
    for (int i = 0; i < 100; ++i) {
        auto close = std::make_shared<std::promise<void>>();
        closed.push_back(close->get_future());
        plx::remote::ConnectionEvents events;
        events.onClosed = [close](const plx::Status&) { close->set_value(); };
        auto c = transport->connect("127.0.0.1", server.port(), "/", {}, std::move(events));
        ASSERT_TRUE(c.isOk()) << c.status().message();
        (*c)->send(bytes);
    }
    for (auto& f : closed)  // each refused and closed, none waiting on the log
        ASSERT_EQ(f.wait_for(std::chrono::seconds(10)), std::future_status::ready);
    RunResult r =
        runParallax("client " + server.url() +
                    " --token abc --walk 10 --scene office:1 --size 64x48 --json --wait 10");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    auto [stopped, code] = server.stop();
    EXPECT_EQ(code, 0);
    ASSERT_TRUE(stopped.is_object());
    EXPECT_EQ(stopped.value("event", ""), "stopped") << stopped.dump();
    EXPECT_EQ(stopped.value("refused", 0), 100);
    EXPECT_EQ(stopped.value("sessions_total", 0), 1);
    EXPECT_GT(stopped.value("lines_dropped", 0), 0);
    transport->stop();
}

TEST(RemoteCli, TokenRefusedAtTheHandshake) {
    ServeProcess server("office:1 --face-size 32 --token abc");
    ASSERT_GT(server.port(), 0);
    fs::path path = scratchDir("remote_cli") / "one.json";
    writeFile(path, R"([{"eye": [1,1.6,1], "target": [4,1.2,5]}])");
    expectOneLineError(runParallax("client " + server.url() + " --path " + path.string() +
                                   " --token abd --size 64x48"),
                       "wrong token");
    expectOneLineError(
        runParallax("client " + server.url() + " --path " + path.string() + " --size 64x48"),
        "token is required");
    auto [stopped, code] = server.stop();
    EXPECT_EQ(code, 0);
    ASSERT_TRUE(stopped.is_object());
    EXPECT_EQ(stopped["sets_sent"], 0);
    EXPECT_TRUE(stopped["render_ms_mean"].is_null()) << stopped;  // no set, no time per set
    EXPECT_TRUE(stopped["encode_ms_mean"].is_null()) << stopped;
    ASSERT_EQ(server.sessionLines.size(), 2u);
    for (const nlohmann::json& line : server.sessionLines)
        EXPECT_EQ(line["event"], "session_refused") << line;
    EXPECT_EQ(server.sessionLines[0]["reason"], "wrong token");
    EXPECT_EQ(server.sessionLines[1]["reason"], "a token is required");
}

TEST(RemoteCli, BadArgumentsAreOneLineErrors) {
    expectOneLineError(runParallax("serve office:1 --refs cube5 --port 0"), "cube5", 2);
    expectOneLineError(runParallax("serve office:1 --face-size 8 --port 0"), "face size", 2);
    expectOneLineError(runParallax("serve office:1 --latency -5 --port 0"), "latency", 2);
    expectOneLineError(runParallax("serve office:1 --max-sessions 0 --port 0"), "max sessions", 2);
    expectOneLineError(runParallax("serve office:1 --max-sessions-per-address 1025 --port 0"),
                       "max sessions per address 1025 outside 0..1024", 2);
    expectOneLineError(runParallax("serve office:1 --write-timeout 0 --port 0"),
                       "write timeout 0 s outside 0.1..3600", 2);
    expectOneLineError(runParallax("serve office:1 --write-timeout nan --port 0"), "write timeout",
                       2);
    expectOneLineError(runParallax("serve office:1 --max-queued 0 --port 0"),
                       "--max-queued 0 MiB outside", 2);
    for (const char* bad : {"0", "65537", "-3"})
        expectOneLineError(runParallax(std::string("serve office:1 --port 0 --max-pending ") + bad),
                           "max pending connections", 2);
    expectOneLineError(runParallax("serve office:1 --prediction magic --port 0"), "magic", 2);
    expectOneLineError(runParallax("serve office:1 --bind 300.1.1.1 --port 0"), "300.1.1.1", 2);
    expectOneLineError(runParallax("serve no-such-scene.glb --port 0"), "no-such-scene.glb");
    expectOneLineError(runParallax("client http://127.0.0.1:1 --walk 3 --scene office:1"), "ws://",
                       2);
    expectOneLineError(runParallax("client ws://127.0.0.1:99999 --walk 3 --scene office:1"),
                       "99999", 2);
    expectOneLineError(runParallax("client ws://127.0.0.1:1 --walk 3"), "--walk needs --scene", 2);
    expectOneLineError(runParallax("client ws://127.0.0.1:1 --scene office:1"), "--path", 2);
    expectOneLineError(runParallax("client ws://127.0.0.1:1 --walk -1 --scene office:1"),
                       "--walk -1 outside", 2);
    expectOneLineError(runParallax("client ws://127.0.0.1:1 --walk 3 --scene office:1 --size 0x4"),
                       "0x4", 2);
    expectOneLineError(
        runParallax("client ws://127.0.0.1:1 --walk 3 --scene office:1 --source-address nope"),
        "source address 'nope' is not an IP address", 2);
    // Nobody listening: the client retries with backoff, then gives up after --wait, saying why
    // its last attempt failed.
    expectOneLineError(runParallax("client ws://127.0.0.1:1 --walk 3 --scene office:1 --wait 0.5"),
                       "within 0.5 s (last: cannot connect to ws://127.0.0.1:1: ");
}

// bench remote's quick run: one real loopback session per RTT, every method's row with the
// issue's JSON fields, the files; bad settings are one-line usage errors.
TEST(RemoteCli, BenchRemoteQuickHasEveryMethodAtEveryRtt) {
    fs::path dir = scratchDir("remote_cli") / "bench";
    RunResult r = runParallax("bench remote --quick --out " + dir.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    for (const char* method : {"warp", "video", "timewarp"})
        for (double rtt : {0.0, 100.0}) {
            int found = 0;
            for (const auto& row : doc["rows"])
                if (row["method"] == method && row["rtt_ms"].get<double>() == rtt) {
                    ++found;
                    for (const char* key :
                         {"rtt_ms", "bandwidth_mbit", "method", "client_fps", "psnr_db_median",
                          "bytes_per_reference", "warp_ms_median", "references_per_s"})
                        EXPECT_TRUE(row.contains(key)) << key;
                    EXPECT_GT(row["client_fps"].get<double>(), 0.0);
                    EXPECT_GT(row["psnr_db_median"].get<double>(), 5.0);
                    EXPECT_GT(row["bytes_per_reference"].get<double>(), 0.0);
                    EXPECT_GT(row["psnr_frames"].get<int>(), 0);
                }
            EXPECT_EQ(found, 1) << method << " at " << rtt << " ms";
        }
    EXPECT_TRUE(fs::exists(dir / "remote.csv"));
    EXPECT_TRUE(fs::exists(dir / "remote.json"));
    EXPECT_TRUE(fs::exists(dir / "psnr_vs_rtt_office_2.svg"));
    expectOneLineError(runParallax("bench remote --quick --rtts=-5 --out " + dir.string()), "RTT",
                       2);
    expectOneLineError(runParallax("bench remote --quick --bandwidths 0 --out " + dir.string()),
                       "bandwidth", 2);
    expectOneLineError(runParallax("bench remote --quick --size 4x4 --out " + dir.string()), "4x4",
                       2);
}

}  // namespace
