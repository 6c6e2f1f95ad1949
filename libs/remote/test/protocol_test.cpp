// Properties of the wire protocol: every message type round-trips, every truncated prefix of
// every message is refused with a one-line error, flipped bits never crash, and oversized,
// unknown or out-of-range fields are refused naming the field. With PLX_UPDATE_GOLDEN=1 it
// rewrites the fuzzers' seed corpus (tests/fuzz/remote-seeds), which must keep decoding.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include <gtest/gtest.h>

#include <plx/remote/protocol.h>

#include "test_sets.h"

namespace plx::remote {
namespace {

warp::Pose tiltedPose() {
    warp::Pose p;
    p.eye = {1.5f, 1.7f, -2.25f};
    p.forward = glm::normalize(Vec3(0.3f, -0.1f, -1.0f));
    p.up = glm::normalize(glm::cross(glm::cross(p.forward, Vec3(0, 1, 0)), p.forward));
    return p;
}

// One message of every type, the reference set a small rendered one.
std::vector<Message> sampleMessages() {
    ReferenceSetMessage set;
    set.sequence = 41;
    set.requestTimestampUs = 123456789012ull;
    set.set = renderedSet("office:1", 16);
    PoseMessage pose{987654321ull, tiltedPose(), true, {0.5f, 0.0f, -1.25f}};
    ServerHello refusal;
    refusal.accepted = false;
    refusal.reason = "unsupported protocol version 2 (server speaks 1)";
    ClientHello browser{1, warp::ReferenceLayout::kCube4, 256, "",
                        disparityCodecBit(DisparityCodec::kQuantized16Deflate)};
    return {ClientHello{1, warp::ReferenceLayout::kCube6, 768, "secret-token"},
            browser,
            ServerHello{},
            refusal,
            pose,
            PoseMessage{5, tiltedPose(), false, Vec3(0.0f)},
            set,
            Ping{77, 0xDEADBEEF},
            Pong{77, 0xDEADBEEF},
            ErrorMessage{ErrorKind::kTooLarge, "reference set message: 70000000 bytes"},
            Bye{ByeReason::kGoingAway, "server shutting down"}};
}

std::vector<uint8_t> encoded(const Message& m) {
    auto bytes = encodeMessage(m);
    EXPECT_TRUE(bytes.isOk()) << bytes.status().toString();
    return bytes.isOk() ? *bytes : std::vector<uint8_t>{};
}

void expectSame(const Message& a, const Message& b) {
    ASSERT_EQ(a.index(), b.index());
    std::visit(
        [&](const auto& x) {
            using T = std::decay_t<decltype(x)>;
            const T& y = std::get<T>(b);
            if constexpr (std::is_same_v<T, ClientHello>) {
                EXPECT_EQ(x.version, y.version);
                EXPECT_EQ(x.layout, y.layout);
                EXPECT_EQ(x.faceSize, y.faceSize);
                EXPECT_EQ(x.token, y.token);
                EXPECT_EQ(x.disparityCodecs, y.disparityCodecs);
            } else if constexpr (std::is_same_v<T, ServerHello>) {
                EXPECT_EQ(x.accepted, y.accepted);
                EXPECT_EQ(x.layout, y.layout);
                EXPECT_EQ(x.faceSize, y.faceSize);
                EXPECT_EQ(x.poseRateHz, y.poseRateHz);
                EXPECT_EQ(x.reason, y.reason);
            } else if constexpr (std::is_same_v<T, PoseMessage>) {
                EXPECT_EQ(x.timestampUs, y.timestampUs);
                EXPECT_EQ(x.pose.eye, y.pose.eye);
                EXPECT_EQ(x.pose.forward, y.pose.forward);
                EXPECT_EQ(x.pose.up, y.pose.up);
                EXPECT_EQ(x.hasVelocity, y.hasVelocity);
                EXPECT_EQ(x.velocity, y.velocity);
            } else if constexpr (std::is_same_v<T, ReferenceSetMessage>) {
                EXPECT_EQ(x.sequence, y.sequence);
                EXPECT_EQ(x.requestTimestampUs, y.requestTimestampUs);
                EXPECT_EQ(x.set.pose.eye, y.set.pose.eye);
                ASSERT_EQ(x.set.views.size(), y.set.views.size());
                for (size_t i = 0; i < x.set.views.size(); ++i) {
                    EXPECT_EQ(x.set.views[i].rowMaxDisparity, y.set.views[i].rowMaxDisparity);
                }
            } else if constexpr (std::is_same_v<T, Ping> || std::is_same_v<T, Pong>) {
                EXPECT_EQ(x.timestampUs, y.timestampUs);
                EXPECT_EQ(x.nonce, y.nonce);
            } else if constexpr (std::is_same_v<T, ErrorMessage>) {
                EXPECT_EQ(x.kind, y.kind);
                EXPECT_EQ(x.text, y.text);
            } else {
                EXPECT_EQ(x.reason, y.reason);
                EXPECT_EQ(x.text, y.text);
            }
        },
        a);
}

TEST(Protocol, EveryMessageTypeRoundTrips) {
    for (const Message& m : sampleMessages()) {
        const std::vector<uint8_t> bytes = encoded(m);
        ASSERT_EQ(bytes[0], uint8_t(messageType(m)));
        auto back = decodeMessage(bytes);
        ASSERT_TRUE(back.isOk()) << back.status().toString();
        expectSame(m, *back);
    }
    EXPECT_EQ(encoded(sampleMessages()[4]).size(), 58u);
}

TEST(Protocol, EveryTruncatedPrefixIsRefused) {
    for (const Message& m : sampleMessages()) {
        const std::vector<uint8_t> bytes = encoded(m);
        for (size_t n = 0; n < bytes.size(); ++n) {
            expectOneLineError(decodeMessage(std::span(bytes).first(n)).status());
        }
    }
}

// The client decodes each set into the buffers of the one before it: the result must not depend
// on what those buffers held (another scene, face size and view count), and a refused message
// names its problem as decodeMessage does.
TEST(Protocol, SetDecodedIntoReusedBuffersEqualsAFreshDecode) {
    ReferenceSetMessage small;
    small.sequence = 3;
    small.set = renderedSet("office:1", 16);
    ReferenceSetMessage big;
    big.sequence = 4;
    big.requestTimestampUs = 99;
    big.set = renderedSet("museum:1", 24);
    const std::vector<uint8_t> bigBytes = encoded(big);
    ReferenceSetMessage reused;
    ASSERT_TRUE(decodeReferenceSetMessage(encoded(small), {}, &reused).isOk());
    ASSERT_TRUE(decodeReferenceSetMessage(bigBytes, {}, &reused).isOk());
    auto fresh = decodeMessage(bigBytes);
    ASSERT_TRUE(fresh.isOk());
    const ReferenceSetMessage& f = std::get<ReferenceSetMessage>(*fresh);
    EXPECT_EQ(reused.sequence, 4u);
    EXPECT_EQ(reused.requestTimestampUs, 99u);
    ASSERT_EQ(reused.set.views.size(), f.set.views.size());
    for (size_t i = 0; i < f.set.views.size(); ++i) {
        const warp::ReferenceView& a = reused.set.views[i];
        const warp::ReferenceView& b = f.set.views[i];
        EXPECT_TRUE(a.color == b.color) << "view " << i;
        EXPECT_TRUE(a.disparity == b.disparity) << "view " << i;
        EXPECT_EQ(a.rowMinDisparity, b.rowMinDisparity);
        EXPECT_EQ(a.rowMaxDisparity, b.rowMaxDisparity);
    }
    for (size_t n = 0; n < bigBytes.size(); n += 97)
        expectOneLineError(decodeReferenceSetMessage(std::span(bigBytes).first(n), {}, &reused));
    const std::vector<uint8_t> ping = encoded(Ping{1, 2});
    expectOneLineError(decodeReferenceSetMessage(ping, {}, &reused));
}

TEST(Protocol, FlippedBitsNeverCrash) {
    std::mt19937 rng(11);
    for (const Message& m : sampleMessages()) {
        const std::vector<uint8_t> good = encoded(m);
        for (int i = 0; i < 1000; ++i) {
            std::vector<uint8_t> bad = good;
            bad[rng() % bad.size()] ^= uint8_t(1u << (rng() % 8));
            auto r = decodeMessage(bad);
            if (!r.isOk()) expectOneLineError(r.status());
        }
    }
}

TEST(Protocol, BadFieldsGetErrorsNamingThem) {
    const std::vector<Message> msgs = sampleMessages();
    std::vector<uint8_t> b = encoded(msgs[0]);
    b.push_back(0);
    expectOneLineError(decodeMessage(b).status(), "1 trailing bytes");
    expectOneLineError(decodeMessage(std::vector<uint8_t>{9, 0, 0}).status(),
                       "unknown message type 9");
    expectOneLineError(decodeMessage(std::vector<uint8_t>{}).status(), "empty");
    b = encoded(msgs[0]);
    b[3] = 7;
    expectOneLineError(decodeMessage(b).status(), "unknown layout 7");
    b = encoded(msgs[0]);
    b[4] = 0xFF;
    b[5] = 0xFF;
    expectOneLineError(decodeMessage(b).status(), "faceSize 65535");
    b = encoded(msgs[2]);
    b[1] = 2;
    expectOneLineError(decodeMessage(b).status(), "protocol version 2");
    b = encoded(msgs[4]);
    b[12] = 0x7F;
    b[11] = 0xC0;  // eye.x = NaN
    expectOneLineError(decodeMessage(b).status(), "eye is not finite");
    b = encoded(msgs[4]);
    b[45] = 3;
    expectOneLineError(decodeMessage(b).status(), "flags 3");
    b = encoded(msgs[0]);
    b.back() = 0;
    expectOneLineError(decodeMessage(b).status(), "disparityCodecs 0x00 names no codec");
    b.back() = 0x1F;
    expectOneLineError(decodeMessage(b).status(), "disparityCodecs 0x1f");
    // A client hello of another version decodes: the server answers with a refusal.
    b = encoded(msgs[0]);
    b[1] = 2;
    ASSERT_TRUE(decodeMessage(b).isOk());
    EXPECT_EQ(std::get<ClientHello>(*decodeMessage(b)).version, 2);
}

TEST(Protocol, OversizedMessagesAreRefusedBeforeReading) {
    std::vector<uint8_t> pose(300, 0);
    pose[0] = uint8_t(MessageType::kPose);
    expectOneLineError(decodeMessage(pose).status(), "300 bytes over the limit 256");
    std::vector<uint8_t> hello = encoded(sampleMessages()[0]);
    hello[6] = 0xFF;  // tokenBytes 65535
    hello[7] = 0xFF;
    expectOneLineError(decodeMessage(hello).status(), "tokenBytes 65535 over 256");
    std::vector<uint8_t> set = encoded(sampleMessages()[6]);
    DecodeLimits small;
    small.maxViewSide = 8;
    expectOneLineError(decodeMessage(set, small).status(), "size 16x16");
}

TEST(Protocol, EncoderRefusesWhatTheDecoderWould) {
    ClientHello h;
    h.faceSize = 8;
    expectOneLineError(encodeMessage(h).status(), "faceSize");
    PoseMessage p;
    p.pose.forward = {0.0f, 0.0f, -2.0f};
    expectOneLineError(encodeMessage(p).status(), "forward is not unit length");
    ServerHello s;
    s.accepted = false;
    expectOneLineError(encodeMessage(s).status(), "reason");
    ClientHello none;
    none.disparityCodecs = 0;
    expectOneLineError(encodeMessage(none).status(), "disparityCodecs");
    ClientHello unknown;
    unknown.disparityCodecs = kAllDisparityCodecs | 0x10;
    expectOneLineError(encodeMessage(unknown).status(), "disparityCodecs");
    ClientHello layout;
    layout.layout = warp::ReferenceLayout(9);
    expectOneLineError(encodeMessage(layout).status(), "unknown layout");
    ServerHello serverLayout;
    serverLayout.layout = warp::ReferenceLayout(9);
    expectOneLineError(encodeMessage(serverLayout).status(), "unknown layout");
}

// Native clients (every codec) get q16-packed, one without it q16 + zstd; a browser (deflate only)
// gets q16 + deflate; the raw floats only to a client that decodes nothing else; a mask naming
// nothing is refused.
TEST(Protocol, ServerPicksTheBestDisparityCodecTheClientDecodes) {
    EXPECT_EQ(*chooseDisparityCodec(kAllDisparityCodecs), DisparityCodec::kQuantized16Packed);
    EXPECT_EQ(*chooseDisparityCodec(kAllDisparityCodecs &
                                    ~disparityCodecBit(DisparityCodec::kQuantized16Packed)),
              DisparityCodec::kQuantized16);
    EXPECT_EQ(*chooseDisparityCodec(disparityCodecBit(DisparityCodec::kQuantized16Deflate)),
              DisparityCodec::kQuantized16Deflate);
    EXPECT_EQ(*chooseDisparityCodec(disparityCodecBit(DisparityCodec::kQuantized16Deflate) |
                                    disparityCodecBit(DisparityCodec::kFloatZstd)),
              DisparityCodec::kQuantized16Deflate);
    EXPECT_EQ(*chooseDisparityCodec(disparityCodecBit(DisparityCodec::kFloatZstd)),
              DisparityCodec::kFloatZstd);
    expectOneLineError(chooseDisparityCodec(0x10).status(), "no disparity codec");
}

// The fuzzers' seeds: every message (protocol fuzzer) and encoded views with each codec pair
// (view fuzzer). Rewritten with PLX_UPDATE_GOLDEN=1; otherwise checked to decode.
TEST(Protocol, FuzzSeedsDecode) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(PLX_SOURCE_DIR) / "tests/fuzz/remote-seeds";
    if (std::getenv("PLX_UPDATE_GOLDEN")) {
        fs::create_directories(dir / "protocol");
        fs::create_directories(dir / "view");
        int i = 0;
        for (const Message& m : sampleMessages()) {
            const std::vector<uint8_t> b = encoded(m);
            std::ofstream(dir / "protocol" / ("msg" + std::to_string(i++) + ".bin"),
                          std::ios::binary)
                .write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
        }
        i = 0;
        for (ColorCodec c : {ColorCodec::kJpeg, ColorCodec::kZstd}) {
            for (DisparityCodec d :
                 {DisparityCodec::kQuantized16, DisparityCodec::kFloatZstd,
                  DisparityCodec::kQuantized16Deflate, DisparityCodec::kQuantized16Packed}) {
                CodecOptions o;
                o.color = c;
                o.disparity = d;
                auto b = encodeReferenceView(renderedSet("museum:1", 16).views[1], o);
                ASSERT_TRUE(b.isOk());
                std::ofstream(dir / "view" / ("view" + std::to_string(i++) + ".bin"),
                              std::ios::binary)
                    .write(reinterpret_cast<const char*>(b->data()), std::streamsize(b->size()));
            }
        }
    }
    if (!fs::exists(dir)) GTEST_SKIP() << "no seed corpus at " << dir;
    for (const char* kind : {"protocol", "view"}) {
        for (const auto& e : fs::directory_iterator(dir / kind)) {
            std::ifstream f(e.path(), std::ios::binary);
            const std::vector<uint8_t> b{std::istreambuf_iterator<char>(f), {}};
            warp::ReferenceView v;
            const Status s = std::string(kind) == "view" ? decodeReferenceView(b, {}, &v)
                                                         : decodeMessage(b).status();
            EXPECT_TRUE(s.isOk()) << e.path() << ": " << s.toString();
        }
    }
}

}  // namespace
}  // namespace plx::remote
