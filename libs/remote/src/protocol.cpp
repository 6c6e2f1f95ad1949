// Encode and decode of every protocol message (docs/remote-protocol.md, "Messages").

#include <plx/remote/protocol.h>

#include <cmath>

#include <fmt/format.h>

#include "bytes.h"

namespace plx::remote {
namespace {

constexpr float kMaxEyeMetres = 1e6f;
constexpr float kUnitTolerance = 1e-3f;  // forward and up: |length - 1|, and sine between them

template <class... Ts>
struct Overloaded : Ts... {
    using Ts::operator()...;
};

bool layoutValid(int v) {
    return v >= 0 && v <= int(warp::ReferenceLayout::kWide);
}
bool faceValid(int v) {
    return v >= kMinFaceSize && v <= kMaxFaceSize;
}

// The reason a pose breaks the protocol's invariants, or empty.
std::string poseProblem(const warp::Pose& p) {
    const auto inBox = [](const Vec3& v, float m) {
        return std::abs(v.x) <= m && std::abs(v.y) <= m && std::abs(v.z) <= m;
    };
    if (!inBox(p.eye, kMaxEyeMetres)) return "eye outside +-1e6 m";
    if (!(std::abs(glm::length(p.forward) - 1.0f) <= kUnitTolerance)) {
        return "forward is not unit length";
    }
    if (!(std::abs(glm::length(p.up) - 1.0f) <= kUnitTolerance)) return "up is not unit length";
    if (!(glm::length(glm::cross(p.forward, p.up)) >= kUnitTolerance)) {
        return "up is parallel to forward";
    }
    return {};
}

void writeText(ByteWriter& w, const std::string& s) {
    w.u16(uint16_t(s.size()));
    w.bytes({reinterpret_cast<const uint8_t*>(s.data()), s.size()});
}

std::string readText(ByteReader& r, const char* field, int maxBytes) {
    const uint16_t n = r.u16(field);
    if (r.ok() && n > maxBytes) r.fail(ErrorCode::kOutOfRange, "{} {} over {}", field, n, maxBytes);
    const auto b = r.bytes(field, n);
    return {b.begin(), b.end()};
}

Status invalid(const char* what, const std::string& problem) {
    return {ErrorCode::kInvalidArgument, fmt::format("{}: {}", what, problem)};
}

// Encoders: each checks what the decoder would refuse, then writes the fields in order.
Status put(ByteWriter& w, const ClientHello& m, const CodecOptions&) {
    if (!layoutValid(int(m.layout))) return invalid("client hello", "unknown layout");
    if (!faceValid(m.faceSize)) return invalid("client hello", "faceSize out of range");
    if (m.token.size() > kMaxTokenBytes) return invalid("client hello", "token too long");
    if (m.disparityCodecs == 0 || (m.disparityCodecs & ~kAllDisparityCodecs) != 0) {
        return invalid("client hello", "disparityCodecs names no codec or an unknown one");
    }
    w.u16(m.version);
    w.u8(uint8_t(m.layout));
    w.u16(uint16_t(m.faceSize));
    writeText(w, m.token);
    w.u8(m.disparityCodecs);
    return {};
}

Status put(ByteWriter& w, const ServerHello& m, const CodecOptions&) {
    if (!layoutValid(int(m.layout))) return invalid("server hello", "unknown layout");
    if (!faceValid(m.faceSize)) return invalid("server hello", "faceSize out of range");
    if (m.poseRateHz < 1 || m.poseRateHz > 1000) return invalid("server hello", "poseRateHz");
    if (m.reason.size() > kMaxTextBytes || m.accepted != m.reason.empty()) {
        return invalid("server hello", "a refusal needs a reason of 1..1024 bytes, an accept none");
    }
    w.u16(m.version);
    w.u8(m.accepted ? 1 : 0);
    w.u8(uint8_t(m.layout));
    w.u16(uint16_t(m.faceSize));
    w.u16(uint16_t(m.poseRateHz));
    writeText(w, m.reason);
    return {};
}

Status put(ByteWriter& w, const PoseMessage& m, const CodecOptions&) {
    if (!isFinite(m.pose.eye) || !isFinite(m.pose.forward) || !isFinite(m.pose.up) ||
        !isFinite(m.velocity)) {
        return invalid("pose", "not finite");
    }
    if (std::string p = poseProblem(m.pose); !p.empty()) return invalid("pose", p);
    const Vec3 v = m.hasVelocity ? m.velocity : Vec3(0.0f);
    if (std::abs(v.x) > kMaxSpeedMps || std::abs(v.y) > kMaxSpeedMps ||
        std::abs(v.z) > kMaxSpeedMps) {
        return invalid("pose", "velocity outside +-1000 m/s");
    }
    w.u64(m.timestampUs);
    w.vec3(m.pose.eye);
    w.vec3(m.pose.forward);
    w.vec3(m.pose.up);
    w.u8(m.hasVelocity ? 1 : 0);
    w.vec3(v);
    return {};
}

Status put(ByteWriter& w, const ReferenceSetMessage& m, const CodecOptions& codec) {
    Result<std::vector<uint8_t>> set = encodeReferenceSet(m.set, codec);
    if (!set) return set.status();
    if (set->size() + 13 > kMaxReferenceSetMessageBytes) {
        return invalid("reference set message", "over 64 MiB");
    }
    w.u32(m.sequence);
    w.u64(m.requestTimestampUs);
    w.bytes(*set);
    return {};
}

Status put(ByteWriter& w, const Ping& m, const CodecOptions&) {
    w.u64(m.timestampUs);
    w.u32(m.nonce);
    return {};
}
Status put(ByteWriter& w, const Pong& m, const CodecOptions&) {
    w.u64(m.timestampUs);
    w.u32(m.nonce);
    return {};
}

Status put(ByteWriter& w, const ErrorMessage& m, const CodecOptions&) {
    if (uint16_t(m.kind) < 1 || uint16_t(m.kind) > 5) return invalid("error", "unknown code");
    if (m.text.size() > kMaxTextBytes) return invalid("error", "text too long");
    w.u16(uint16_t(m.kind));
    writeText(w, m.text);
    return {};
}

Status put(ByteWriter& w, const Bye& m, const CodecOptions&) {
    if (uint16_t(m.reason) > 2) return invalid("bye", "unknown reason");
    if (m.text.size() > kMaxTextBytes) return invalid("bye", "text too long");
    w.u16(uint16_t(m.reason));
    writeText(w, m.text);
    return {};
}

// Decoders: read the fields in order; the caller checks the reader and the end.
void readLayoutAndFace(ByteReader& r, warp::ReferenceLayout* layout, int* faceSize) {
    const uint8_t l = r.u8("layout");
    if (r.ok() && !layoutValid(l)) r.fail(ErrorCode::kCorruptData, "unknown layout {}", l);
    *layout = warp::ReferenceLayout(l);
    *faceSize = r.u16("faceSize");
    if (r.ok() && !faceValid(*faceSize)) {
        r.fail(ErrorCode::kOutOfRange, "faceSize {} outside 16..4096", *faceSize);
    }
}

ClientHello getClientHello(ByteReader& r) {
    ClientHello m;
    m.version = r.u16("version");
    readLayoutAndFace(r, &m.layout, &m.faceSize);
    m.token = readText(r, "tokenBytes", kMaxTokenBytes);
    m.disparityCodecs = r.u8("disparityCodecs");
    if (r.ok() && (m.disparityCodecs == 0 || (m.disparityCodecs & ~kAllDisparityCodecs) != 0)) {
        r.fail(ErrorCode::kCorruptData, "disparityCodecs {:#04x} names no codec or an unknown one",
               m.disparityCodecs);
    }
    return m;
}

ServerHello getServerHello(ByteReader& r) {
    ServerHello m;
    m.version = r.u16("version");
    if (r.ok() && m.version != kProtocolVersion) {
        r.fail(ErrorCode::kUnsupported, "protocol version {} (this client speaks {})", m.version,
               kProtocolVersion);
    }
    const uint8_t accepted = r.u8("accepted");
    if (r.ok() && accepted > 1) r.fail(ErrorCode::kCorruptData, "accepted is {}", accepted);
    m.accepted = accepted == 1;
    readLayoutAndFace(r, &m.layout, &m.faceSize);
    m.poseRateHz = r.u16("poseRateHz");
    if (r.ok() && (m.poseRateHz < 1 || m.poseRateHz > 1000)) {
        r.fail(ErrorCode::kOutOfRange, "poseRateHz {} outside 1..1000", m.poseRateHz);
    }
    m.reason = readText(r, "reasonBytes", kMaxTextBytes);
    if (r.ok() && m.accepted != m.reason.empty()) {
        r.fail(ErrorCode::kCorruptData, "reasonBytes {} for accepted {}", m.reason.size(),
               accepted);
    }
    return m;
}

PoseMessage getPose(ByteReader& r) {
    PoseMessage m;
    m.timestampUs = r.u64("timestampUs");
    m.pose.eye = r.vec3("eye");
    m.pose.forward = r.vec3("forward");
    m.pose.up = r.vec3("up");
    const uint8_t flags = r.u8("flags");
    m.velocity = r.vec3("velocity");
    if (!r.ok()) return m;
    if (std::string p = poseProblem(m.pose); !p.empty()) {
        r.fail(ErrorCode::kCorruptData, "{}", p);
    } else if (flags > 1) {
        r.fail(ErrorCode::kCorruptData, "flags {} has unknown bits", flags);
    } else if (std::abs(m.velocity.x) > kMaxSpeedMps || std::abs(m.velocity.y) > kMaxSpeedMps ||
               std::abs(m.velocity.z) > kMaxSpeedMps) {
        r.fail(ErrorCode::kOutOfRange, "velocity outside +-1000 m/s");
    } else if (flags == 0 && m.velocity != Vec3(0.0f)) {
        r.fail(ErrorCode::kCorruptData, "velocity non-zero without its flag");
    }
    m.hasVelocity = flags == 1;
    return m;
}

ErrorMessage getError(ByteReader& r) {
    ErrorMessage m;
    const uint16_t code = r.u16("code");
    if (r.ok() && (code < 1 || code > 5)) r.fail(ErrorCode::kCorruptData, "unknown code {}", code);
    m.kind = ErrorKind(code);
    m.text = readText(r, "textBytes", kMaxTextBytes);
    return m;
}

Bye getBye(ByteReader& r) {
    Bye m;
    const uint16_t code = r.u16("code");
    if (r.ok() && code > 2) r.fail(ErrorCode::kCorruptData, "unknown reason {}", code);
    m.reason = ByeReason(code);
    m.text = readText(r, "textBytes", kMaxTextBytes);
    return m;
}

// The decoded message, or the reader's error once everything was read.
template <class T>
Result<Message> finish(ByteReader& r, T&& m) {
    r.expectEnd();
    if (!r.ok()) return r.status();
    return Message(std::forward<T>(m));
}

}  // namespace

MessageType messageType(const Message& message) {
    return MessageType(message.index() + 1);  // the variant lists the types in wire order
}

const char* messageTypeName(MessageType type) {
    static const char* const kNames[] = {"client hello", "server hello", "pose",  "reference set",
                                         "ping",         "pong",         "error", "bye"};
    const int i = int(type) - 1;
    return i >= 0 && i < 8 ? kNames[i] : "unknown";
}

bool mayBeSentBy(std::span<const uint8_t> message, Peer sender) {
    if (message.empty()) return true;
    switch (MessageType(message[0])) {
        case MessageType::kClientHello:
        case MessageType::kPose:
            return sender == Peer::kClient;
        case MessageType::kServerHello:
        case MessageType::kReferenceSet:
            return sender == Peer::kServer;
        default:
            return true;
    }
}

Result<std::vector<uint8_t>> encodeMessage(const Message& message, const CodecOptions& codec) {
    std::vector<uint8_t> out;
    ByteWriter w(&out);
    w.u8(uint8_t(messageType(message)));
    const Status s = std::visit([&](const auto& m) { return put(w, m, codec); }, message);
    if (!s.isOk()) return s;
    return out;
}

Status decodeReferenceSetMessage(std::span<const uint8_t> bytes, const DecodeLimits& limits,
                                 ReferenceSetMessage* out) {
    if (bytes.empty() || bytes[0] != uint8_t(MessageType::kReferenceSet))
        return Status(ErrorCode::kCorruptData, "reference set message: wrong type byte");
    if (bytes.size() > kMaxReferenceSetMessageBytes) {
        return Status(ErrorCode::kOutOfRange,
                      fmt::format("reference set message: {} bytes over the limit {}", bytes.size(),
                                  kMaxReferenceSetMessageBytes));
    }
    ByteReader r(bytes, "reference set message");
    r.u8("type");
    out->sequence = r.u32("sequence");
    out->requestTimestampUs = r.u64("requestTimestampUs");
    if (!r.ok()) return r.status();
    const Status s = decodeReferenceSet(bytes.subspan(r.position()), limits, &out->set);
    if (!s.isOk()) return Status(s.code(), "reference set message: " + s.message());
    return Status::ok();
}

DecodeLimits announcedLimits(const ServerHello& hello, const DecodeLimits& base) {
    const bool wide = hello.layout == warp::ReferenceLayout::kWide;
    DecodeLimits l;
    l.maxViewSide = wide ? base.maxViewSide : std::min(base.maxViewSide, hello.faceSize);
    l.maxViewPixels = std::min(base.maxViewPixels, int64_t(hello.faceSize) * l.maxViewSide);
    l.maxViews = std::min(base.maxViews, warp::referenceViewCount(hello.layout));
    l.maxSetPixels = std::min(base.maxSetPixels, l.maxViewPixels * l.maxViews);
    return l;
}

Result<Message> decodeMessage(std::span<const uint8_t> bytes, const DecodeLimits& limits) {
    if (bytes.empty()) return Status(ErrorCode::kCorruptData, "message: empty");
    const auto type = MessageType(bytes[0]);
    if (type == MessageType::kReferenceSet) {  // its own size limit and checks
        ReferenceSetMessage m;
        if (Status s = decodeReferenceSetMessage(bytes, limits, &m); !s.isOk()) return s;
        return Message(std::move(m));
    }
    const size_t limit = type == MessageType::kPose          ? kMaxPoseMessageBytes
                         : type == MessageType::kClientHello ? 512
                                                             : 2048;
    if (bytes.size() > limit) {
        return Status(ErrorCode::kOutOfRange,
                      fmt::format("{} message: {} bytes over the limit {}", messageTypeName(type),
                                  bytes.size(), limit));
    }
    ByteReader r(bytes, std::string(messageTypeName(type)) + " message");
    r.u8("type");
    switch (type) {
        case MessageType::kClientHello:
            return finish(r, getClientHello(r));
        case MessageType::kServerHello:
            return finish(r, getServerHello(r));
        case MessageType::kPose:
            return finish(r, getPose(r));
        case MessageType::kPing: {
            Ping m{r.u64("timestampUs"), r.u32("nonce")};
            return finish(r, m);
        }
        case MessageType::kPong: {
            Pong m{r.u64("timestampUs"), r.u32("nonce")};
            return finish(r, m);
        }
        case MessageType::kError:
            return finish(r, getError(r));
        case MessageType::kBye:
            return finish(r, getBye(r));
        default:
            break;
    }
    return Status(ErrorCode::kUnsupported, fmt::format("unknown message type {}", bytes[0]));
}

}  // namespace plx::remote
