#pragma once
// At most one unwritten message of a kind on a connection (docs/remote-protocol.md, "Limits"): a
// Ping or Pong that finds the one sent before it still queued behind a peer that has stopped
// reading is not sent, so such a peer cannot make this side queue without bound.

#include <atomic>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <plx/remote/transport.h>

namespace plx::remote {

class OneUnwritten {
public:
    // Queues `message` on `conn` unless the message this slot queued before is still unwritten,
    // else drops it.
    void send(Connection& conn, std::vector<uint8_t> message) {
        if (mUnwritten->exchange(true)) return;
        conn.send(std::move(message),
                  [unwritten = mUnwritten](const Status&) { unwritten->store(false); });
    }

private:
    // Shared with the send's completion, which may run after the slot's owner is gone.
    std::shared_ptr<std::atomic<bool>> mUnwritten = std::make_shared<std::atomic<bool>>(false);
};

}  // namespace plx::remote
