#pragma once
// At most one unwritten message of a kind on a connection (docs/remote-protocol.md, "Limits"): a
// Ping or Pong that finds the one sent before it still queued behind a peer that has stopped
// reading is not sent, so such a peer cannot make this side queue without bound.

#include <atomic>
#include <memory>

#include <plx/remote/protocol.h>
#include <plx/remote/transport.h>

namespace plx::remote {

class OneUnwritten {
public:
    // Encodes and queues `message` on `conn` unless the message this slot queued before is
    // still unwritten, else drops it (unencoded).
    void send(Connection& conn, const Message& message) {
        if (mUnwritten->exchange(true)) return;
        auto bytes = encodeMessage(message);
        if (!bytes) {  // well-formed by construction; nothing to send otherwise
            mUnwritten->store(false);
            return;
        }
        conn.send(std::move(bytes).value(),
                  [unwritten = mUnwritten](const Status&) { unwritten->store(false); });
    }

private:
    // Shared with the send's completion, which may run after the slot's owner is gone.
    std::shared_ptr<std::atomic<bool>> mUnwritten = std::make_shared<std::atomic<bool>>(false);
};

}  // namespace plx::remote
