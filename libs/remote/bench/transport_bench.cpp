// Loopback latency of the transport for the protocol's small messages (poses, pings, pongs): the
// client writes two small messages at once and waits for the server's echo of both. With Nagle's
// algorithm on, the server's second echo waits for the client's delayed ACK of the first (up to
// 40 ms on Linux); the transport turns it off when a connection is made (transport.cpp,
// tcpConnected). docs/remote-results.md gives the figures.
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <vector>

#include <benchmark/benchmark.h>

#include <plx/remote/transport.h>

namespace {

using namespace plx::remote;

void BM_TwoSmallMessagesEchoed(benchmark::State& state) {
    auto server = std::move(Transport::create()).value();
    auto port = server->listen("127.0.0.1", 0, {}, [](std::shared_ptr<Connection> c) {
        ConnectionEvents events;
        events.onMessage = [weak = std::weak_ptr(c)](std::vector<uint8_t>&& m, bool) {
            if (auto conn = weak.lock()) conn->send(std::move(m));
        };
        return events;
    });
    auto client = std::move(Transport::create()).value();
    std::mutex mutex;
    std::condition_variable changed;
    int echoed = 0;
    ConnectionEvents events;
    events.onMessage = [&](std::vector<uint8_t>&&, bool) {
        std::lock_guard lock(mutex);
        ++echoed;
        changed.notify_one();
    };
    auto conn =
        port ? client->connect("127.0.0.1", *port, "/", {}, std::move(events)) : port.status();
    if (!conn) {
        state.SkipWithError(conn.status().message().c_str());
        return;
    }
    const std::vector<uint8_t> message(20, 1);  // a Ping's size
    for (auto _ : state) {
        {
            std::lock_guard lock(mutex);
            echoed = 0;
        }
        (*conn)->send(message);
        (*conn)->send(message);
        std::unique_lock lock(mutex);
        if (!changed.wait_for(lock, std::chrono::seconds(5), [&] { return echoed == 2; })) {
            state.SkipWithError("no echo within 5 s");
            break;
        }
    }
    (*conn)->abort();
    client->stop();
    server->stop();
}
BENCHMARK(BM_TwoSmallMessagesEchoed)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace
