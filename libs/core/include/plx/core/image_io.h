#pragma once
// Reading PNG and JPEG files and writing PNG files. Files are untrusted: every failure comes back
// as a Status naming the file and the problem; nothing here aborts on bad bytes.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <plx/core/image.h>
#include <plx/core/status.h>

namespace plx {

// Largest image side and pixel count ever accepted from a file (guards against absurd headers).
constexpr int kMaxDecodedSide = 32768;
constexpr int64_t kMaxDecodedPixels = int64_t(1) << 28;
// The default pixel limit of a decode: 64 Mpix (256 MiB as RGBA8), above any texture a renderer
// here uses, while a few hundred bytes of compressed zeros declaring 16384x16384 are refused
// before gigabytes are allocated. Callers raise it (up to kMaxDecodedPixels) on request.
constexpr int64_t kDefaultMaxPixels = int64_t(1) << 26;

// Decodes PNG or JPEG bytes (sniffed from the signature) keeping the file's channel count
// (1-4; 16-bit PNGs are reduced to 8 bits, palettes expanded). An image declaring more than
// maxPixels pixels is refused (kOutOfRange) before its pixels are allocated.
Result<ByteImage> decodeImage(std::span<const uint8_t> bytes,
                              int64_t maxPixels = kDefaultMaxPixels);
// Reads and decodes a PNG or JPEG file.
Result<ByteImage> readImage(const std::string& path, int64_t maxPixels = kDefaultMaxPixels);

// Encodes a PNG. compressionLevel is zlib's 0-9. Errors (kInvalidArgument): channels outside
// 1-4, an empty image, bytes not of the image's size.
Result<std::vector<uint8_t>> encodePng(const ByteImage& image, int compressionLevel = 6);
Status writePng(const std::string& path, const ByteImage& image, int compressionLevel = 6);
Status writePng(const std::string& path, const Image<Rgba8>& image, int compressionLevel = 6);

// Whole-file helpers used by every module that reads or writes files. readFileBytes reads through
// readFileChecked (<plx/core/file.h>): regular files only, errors naming the cause.
Result<std::vector<uint8_t>> readFileBytes(const std::string& path);
Status writeFileBytes(const std::string& path, std::span<const uint8_t> bytes);

}  // namespace plx
