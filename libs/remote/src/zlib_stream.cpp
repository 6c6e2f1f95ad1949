// One-shot zlib streams (RFC 1950: a 2-byte header, deflate data, an Adler-32 trailer), the
// entropy coder of the q16-deflate disparity payload: what a browser's
// DecompressionStream('deflate') inflates, where zstd is not available. A zlib stream records no
// content size, so the decoder checks its header before anything is allocated and inflates into
// a buffer of exactly the size the view header promised: a stream that would produce one byte
// more, or end one byte short, is refused.

#include <zlib.h>

#include <fmt/format.h>

#include "payloads.h"

namespace plx::remote {

Status zlibCompress(std::span<const uint8_t> in, int level, std::vector<uint8_t>* out) {
    uLongf n = compressBound(uLong(in.size()));
    out->resize(n);
    const int rc = compress2(out->data(), &n, in.data(), uLong(in.size()), level);
    if (rc != Z_OK) return {ErrorCode::kInternal, fmt::format("zlib: compress2 returned {}", rc)};
    out->resize(n);
    return {};
}

Status checkZlibHeader(std::span<const uint8_t> in, const char* field) {
    // RFC 1950 2.2: CMF = method 8 (deflate) with a window of at most 2^15; FLG's check bits make
    // CMF * 256 + FLG a multiple of 31; no preset dictionary (FDICT), which a decoder could not
    // know. The smallest stream (empty data) is 8 bytes.
    if (in.size() < 8) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: zlib stream of {} bytes is too short", field, in.size())};
    }
    const unsigned cmf = in[0], flg = in[1];
    if ((cmf & 0x0F) != 8 || (cmf >> 4) > 7 || (cmf * 256 + flg) % 31 != 0 || (flg & 0x20) != 0) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: not a zlib deflate stream (header {:02x} {:02x})", field, cmf,
                            flg)};
    }
    return {};
}

Status zlibInflateExact(std::span<const uint8_t> in, std::span<uint8_t> out, const char* field) {
    PLX_RETURN_IF_ERROR(checkZlibHeader(in, field));
    z_stream z{};
    if (inflateInit(&z) != Z_OK) return {ErrorCode::kInternal, "zlib: inflateInit failed"};
    z.next_in = const_cast<Bytef*>(in.data());
    z.avail_in = uInt(in.size());
    z.next_out = out.data();
    z.avail_out = uInt(out.size());
    // One call with the whole input and exactly the promised output: Z_STREAM_END means the
    // stream ended (Adler-32 checked) within the buffer; anything else is a damaged, short or
    // long stream. inflate never writes past avail_out.
    const int rc = inflate(&z, Z_FINISH);
    const size_t produced = out.size() - z.avail_out, unread = z.avail_in;
    const char* message = z.msg ? z.msg : "truncated stream";
    inflateEnd(&z);
    if (rc == Z_BUF_ERROR && produced == out.size()) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: zlib stream inflates past {} bytes", field, out.size())};
    }
    if (rc != Z_STREAM_END) {
        return {ErrorCode::kCorruptData, fmt::format("{}: zlib: {} after {} of {} bytes", field,
                                                     message, produced, out.size())};
    }
    if (produced != out.size()) {
        return {ErrorCode::kCorruptData, fmt::format("{}: zlib stream of {} bytes, expected {}",
                                                     field, produced, out.size())};
    }
    if (unread != 0) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: {} bytes after the zlib stream", field, unread)};
    }
    return {};
}

}  // namespace plx::remote
