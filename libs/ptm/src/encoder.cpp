#include <fmt/format.h>
#include <zstd.h>

#include <plx/ptm/encoder.h>

#include "codec.h"

namespace plx::ptm {
namespace {

// The uncompressed payload of group k (layout in codec.h).
std::vector<uint8_t> buildPayload(const std::vector<ByteImage>& chain, int k, Coder coder) {
    ByteImage level = chain[size_t(k)];  // the walker's encode mode reads but takes a mutable ptr
    const detail::GroupLayout layout =
        detail::groupLayout({level.width, level.height}, level.channels, k == 0);
    std::vector<uint8_t> payload(layout.payloadBytes(), 0);
    const bool predict = coder == Coder::kPredictZstd;
    if (k == 0) {
        if (predict)
            detail::walkLowest<true, true>(level.bytes.data(), level.width, level.height,
                                           level.channels, payload.data());
        else
            detail::walkLowest<false, true>(level.bytes.data(), level.width, level.height,
                                            level.channels, payload.data());
    } else if (predict) {
        detail::walkLevelAny<true, true>(level.channels, chain[size_t(k - 1)], level.bytes.data(),
                                         level.width, level.height, payload.data());
    } else {
        detail::walkLevelAny<false, true>(level.channels, chain[size_t(k - 1)],
                                          level.bytes.data(), level.width, level.height,
                                          payload.data());
    }
    return payload;
}

Result<std::vector<uint8_t>> compress(const std::vector<uint8_t>& payload, int level) {
    std::vector<uint8_t> out(ZSTD_compressBound(payload.size()));
    const size_t n = ZSTD_compress(out.data(), out.size(), payload.data(), payload.size(), level);
    if (ZSTD_isError(n))
        return errorStatus(ErrorCode::kInternal, fmt::format("zstd: {}", ZSTD_getErrorName(n)));
    out.resize(n);
    return out;
}

}  // namespace

int storedLevelCount(int width, int height, const EncodeConfig& config) {
    PLX_CHECK(width >= 1 && height >= 1 && config.lowestMaxSide >= 1);
    int count = 1;
    LevelSize s{width, height};
    while (std::max(s.width, s.height) > config.lowestMaxSide) {
        s = lowerLevelSize(s);
        ++count;
    }
    return count;
}

Result<std::vector<uint8_t>> encode(const ByteImage& image, const EncodeConfig& config) {
    if (image.channels < 1 || image.channels > 4)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("PTM encode: {} channels (need 1-4)", image.channels));
    if (image.width < 1 || image.height < 1 || image.width > kMaxSide ||
        image.height > kMaxSide || int64_t(image.width) * image.height > kMaxPixels)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("PTM encode: size {}x{} outside 1x1..{}x{}", image.width,
                                       image.height, kMaxSide, kMaxSide));
    if (image.bytes.size() != image.rowBytes() * size_t(image.height))
        return errorStatus(ErrorCode::kInvalidArgument, "PTM encode: pixel buffer size mismatch");
    if (config.lowestMaxSide < 1)
        return errorStatus(ErrorCode::kInvalidArgument, "PTM encode: lowestMaxSide must be >= 1");
    if (config.coder == Coder::kPredictZstd &&
        (config.zstdLevel < 1 || config.zstdLevel > ZSTD_maxCLevel()))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("PTM encode: zstd level {} outside 1..{}", config.zstdLevel,
                                       ZSTD_maxCLevel()));
    const int count = storedLevelCount(image.width, image.height, config);
    const std::vector<ByteImage> chain = buildMipChain(image, count);  // eq. (1)
    Header header;
    header.width = image.width;
    header.height = image.height;
    header.components = image.channels;
    header.levelCount = count;
    header.lowest = {chain[0].width, chain[0].height};
    header.coder = config.coder;
    std::vector<std::vector<uint8_t>> groups;
    uint64_t offset = headerBytesFor(count);
    for (int k = 0; k < count; ++k) {
        std::vector<uint8_t> payload = buildPayload(chain, k, config.coder);
        if (config.coder == Coder::kPredictZstd) {
            auto packed = compress(payload, config.zstdLevel);
            if (!packed) return packed.status();
            payload = std::move(packed).value();
        }
        header.groups.push_back({offset, payload.size(), crc32(payload)});
        offset += payload.size();
        groups.push_back(std::move(payload));
    }
    std::vector<uint8_t> file = writeHeader(header);
    file.reserve(offset);
    for (const auto& g : groups) file.insert(file.end(), g.begin(), g.end());
    return file;
}

}  // namespace plx::ptm
