// The server's choice of disparity codec from what a client says it decodes (ClientHello's
// disparityCodecs, docs/remote-protocol.md).

#include <fmt/format.h>

#include <plx/remote/protocol.h>

namespace plx::remote {

Result<DisparityCodec> chooseDisparityCodec(uint8_t disparityCodecs) {
    // In order of preference: q16-packed codes and decodes fastest; q16 + zstd is the smallest;
    // q16 + deflate costs a little more time and bytes (docs/remote-results.md); the raw floats
    // are 3-4x larger.
    for (DisparityCodec c : {DisparityCodec::kQuantized16Packed, DisparityCodec::kQuantized16,
                             DisparityCodec::kQuantized16Deflate, DisparityCodec::kFloatZstd}) {
        if ((disparityCodecs & disparityCodecBit(c)) != 0) return c;
    }
    return Status(ErrorCode::kUnsupported,
                  fmt::format("client decodes no disparity codec this server sends (mask {:#04x})",
                              disparityCodecs));
}

}  // namespace plx::remote
