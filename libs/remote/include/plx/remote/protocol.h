#pragma once
// The remote rendering wire protocol, version 1 (docs/remote-protocol.md): one WebSocket binary
// message = one protocol message = a type byte, the type's fixed header, its payload; all
// little-endian. Encoders take well-formed messages (preconditions below); decoders take
// untrusted bytes and return one-line errors naming the field.

#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include <plx/core/status.h>
#include <plx/remote/codec.h>
#include <plx/warp/warp.h>

namespace plx::remote {

constexpr uint16_t kProtocolVersion = 1;

enum class MessageType : uint8_t {
    kClientHello = 1,
    kServerHello = 2,
    kPose = 3,
    kReferenceSet = 4,
    kPing = 5,
    kPong = 6,
    kError = 7,
    kBye = 8,
};

// Limits of docs/remote-protocol.md.
constexpr int kMaxTokenBytes = 256;
constexpr int kMaxTextBytes = 1024;  // refusal reasons, error and bye texts
constexpr int kMinFaceSize = 16;
constexpr int kMaxFaceSize = 4096;
constexpr size_t kMaxPoseMessageBytes = 256;
constexpr size_t kMaxReferenceSetMessageBytes = size_t(64) << 20;

// The ClientHello's disparityCodecs bit of a codec: bit (codec - 1).
constexpr uint8_t disparityCodecBit(DisparityCodec codec) {
    return uint8_t(1u << (uint8_t(codec) - 1));
}
// Every disparity codec of this version: what a native client decodes.
constexpr uint8_t kAllDisparityCodecs = 0x0f;

// The first message of a session, client to server.
struct ClientHello {
    uint16_t version = kProtocolVersion;                           // the client's protocol version
    warp::ReferenceLayout layout = warp::ReferenceLayout::kCube4;  // requested
    int faceSize = 512;  // requested pixels per face side, kMinFaceSize..kMaxFaceSize
    std::string token;   // opaque credential, at most kMaxTokenBytes
    // The disparity codecs the client decodes (disparityCodecBit of each; at least one, no
    // unknown bits). A browser has no zstd and sends only kQuantized16Deflate's bit.
    uint8_t disparityCodecs = kAllDisparityCodecs;
};

// The disparity codec a server sends to a client that decodes `disparityCodecs`: q16 with zstd
// when it can (the smallest and fastest, docs/remote-results.md), else q16 with deflate, else the
// raw floats. Error (kUnsupported) when the mask names none of them.
Result<DisparityCodec> chooseDisparityCodec(uint8_t disparityCodecs);

// The server's answer: accepted with what it will send, or refused with a reason.
struct ServerHello {
    uint16_t version = kProtocolVersion;
    bool accepted = true;
    warp::ReferenceLayout layout = warp::ReferenceLayout::kCube4;
    int faceSize = 512;    // kMinFaceSize..kMaxFaceSize
    int poseRateHz = 120;  // Pose messages per second it reads, 1..1000
    std::string reason;    // empty when accepted, 1..kMaxTextBytes when refused
};

// What the sets of a session that `hello` accepted may hold, within `base`: the layout's views,
// each at most faceSize square (a wide view faceSize high and up to base.maxViewSide wide). A
// set beyond them is refused before its pixels are decoded.
DecodeLimits announcedLimits(const ServerHello& hello, const DecodeLimits& base);

// A tracked head pose, client to server.
// The largest speed a Pose's velocity may give, per component, m/s: well past any head or
// vehicle. The server's own estimate from successive poses is held to it too.
constexpr float kMaxSpeedMps = 1000.0f;

struct PoseMessage {
    uint64_t timestampUs = 0;  // tracker sample time, client clock
    warp::Pose pose;           // eye within +-1e6 m; forward, up unit within 1e-3, not parallel
    bool hasVelocity = false;
    Vec3 velocity{0.0f};  // metres per second, each component within +-1000; 0 without velocity
};

// A reference set rendered for a pose, server to client.
struct ReferenceSetMessage {
    uint32_t sequence = 0;            // 0, 1, 2, ... per session
    uint64_t requestTimestampUs = 0;  // the pose's timestampUs, echoed
    warp::ReferenceSet set;
};

struct Ping {
    uint64_t timestampUs = 0;  // sender's clock
    uint32_t nonce = 0;
};
struct Pong {
    uint64_t timestampUs = 0;  // copied from the Ping
    uint32_t nonce = 0;
};

enum class ErrorKind : uint16_t {
    kProtocol = 1,
    kTooLarge = 2,
    kUnauthorized = 3,
    kOverloaded = 4,
    kInternal = 5,
};
struct ErrorMessage {
    ErrorKind kind = ErrorKind::kProtocol;
    std::string text;  // one line, at most kMaxTextBytes
};

enum class ByeReason : uint16_t { kNormal = 0, kGoingAway = 1, kIdleTimeout = 2 };
struct Bye {
    ByeReason reason = ByeReason::kNormal;
    std::string text;  // at most kMaxTextBytes
};

using Message = std::variant<ClientHello, ServerHello, PoseMessage, ReferenceSetMessage, Ping, Pong,
                             ErrorMessage, Bye>;

MessageType messageType(const Message& message);
const char* messageTypeName(MessageType type);

// The direction column of docs/remote-protocol.md: false when the message's first byte names a
// type only the other side sends (a ServerHello or ReferenceSet from a client, a ClientHello or
// Pose from the server), which each side refuses by its type, before decoding it. Unknown types
// pass here; the decoder refuses them.
enum class Peer { kClient, kServer };
bool mayBeSentBy(std::span<const uint8_t> message, Peer sender);

// Encodes one message. codec applies to reference sets only. Errors (kInvalidArgument): a field
// outside its documented range (the decoder would refuse it), a set the codec refuses.
Result<std::vector<uint8_t>> encodeMessage(const Message& message, const CodecOptions& codec = {});

// Decodes one message from untrusted bytes: sizes checked before allocation (reference sets
// against `limits`), floats finite and in range, unknown types and versions and trailing bytes
// refused. A ClientHello of another version decodes (the server answers it with a refusal);
// every other message is version 1 by the session's handshake.
Result<Message> decodeMessage(std::span<const uint8_t> bytes, const DecodeLimits& limits = {});

// Decodes a reference set message (type byte kReferenceSet) into *out, reusing its buffers: the
// same checks and errors as decodeMessage. A client that keeps one set while it decodes the next
// allocates nothing per set.
Status decodeReferenceSetMessage(std::span<const uint8_t> bytes, const DecodeLimits& limits,
                                 ReferenceSetMessage* out);

}  // namespace plx::remote
