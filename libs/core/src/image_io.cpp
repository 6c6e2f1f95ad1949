#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <fstream>

#include <fmt/format.h>
#include <jpeglib.h>
#include <png.h>

#include <plx/core/file.h>
#include <plx/core/image_io.h>

namespace plx {
namespace {

// Checked on the declared size, before the pixels are allocated.
Status checkDecodedSize(int64_t width, int64_t height, const char* format, int64_t maxPixels) {
    if (width < 1 || height < 1)
        return errorStatus(ErrorCode::kCorruptData, fmt::format("{} declares an empty image", format));
    if (width > kMaxDecodedSide || height > kMaxDecodedSide)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("{} declares {}x{} pixels, more than the {}x{} limit",
                                       format, width, height, kMaxDecodedSide, kMaxDecodedSide));
    if (width * height > std::min(maxPixels, kMaxDecodedPixels))
        return errorStatus(
            ErrorCode::kOutOfRange,
            fmt::format("{} declares {}x{} pixels, more than the limit of {} pixels", format, width,
                        height, std::min(maxPixels, kMaxDecodedPixels)));
    return Status::ok();
}

Result<ByteImage> decodePng(std::span<const uint8_t> bytes, int64_t maxPixels) {
    png_image image;
    std::memset(&image, 0, sizeof(image));
    image.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
        return errorStatus(ErrorCode::kCorruptData, fmt::format("PNG: {}", image.message));
    Status sizeOk = checkDecodedSize(image.width, image.height, "PNG", maxPixels);
    if (!sizeOk) {
        png_image_free(&image);
        return sizeOk;
    }
    bool color = image.format & PNG_FORMAT_FLAG_COLOR;
    bool alpha = image.format & PNG_FORMAT_FLAG_ALPHA;
    ByteImage out;
    out.width = int(image.width);
    out.height = int(image.height);
    out.channels = (color ? 3 : 1) + (alpha ? 1 : 0);
    image.format = color ? (alpha ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB)
                         : (alpha ? PNG_FORMAT_GA : PNG_FORMAT_GRAY);
    out.bytes.resize(size_t(out.width) * out.height * out.channels);
    if (!png_image_finish_read(&image, nullptr, out.bytes.data(), 0, nullptr))
        return errorStatus(ErrorCode::kCorruptData, fmt::format("PNG: {}", image.message));
    return out;
}

struct JpegErrorManager {
    jpeg_error_mgr base;
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
    char warning[JMSG_LENGTH_MAX];  // the first corrupt-data warning; empty: none
};

void jpegErrorExit(j_common_ptr info) {
    auto* err = reinterpret_cast<JpegErrorManager*>(info->err);
    (*info->err->format_message)(info, err->message);
    std::longjmp(err->jump, 1);
}
// libjpeg reports damaged data (a truncated file, a corrupt segment) as a warning (level -1) and
// fills what it could not decode with grey; the first one is kept so that the decode fails.
// Trace messages (levels > 0) stay silent.
void jpegWarning(j_common_ptr info, int level) {
    auto* err = reinterpret_cast<JpegErrorManager*>(info->err);
    if (level < 0 && err->warning[0] == '\0') (*info->err->format_message)(info, err->warning);
}

// Why a JPEG decode failed, as plain data: decodeJpegInto calls setjmp, and its message is
// formed outside it (jpegFailureText).
struct JpegFailure {
    enum class Kind { kLibjpeg, kTooLarge, kDamaged } kind = Kind::kLibjpeg;
    char text[JMSG_LENGTH_MAX] = "";  // libjpeg's error or first warning
    unsigned width = 0, height = 0;   // the declared size, for kTooLarge
};

// Kept free of C++ objects with destructors between setjmp and longjmp, as the standard requires.
bool decodeJpegInto(std::span<const uint8_t> bytes, int64_t maxPixels, ByteImage* out,
                    JpegFailure* failure) {
    jpeg_decompress_struct info;
    JpegErrorManager err;
    info.err = jpeg_std_error(&err.base);
    err.base.error_exit = jpegErrorExit;
    err.base.emit_message = jpegWarning;
    err.warning[0] = '\0';
    if (setjmp(err.jump)) {
        failure->kind = JpegFailure::Kind::kLibjpeg;
        std::memcpy(failure->text, err.message, sizeof(failure->text));
        jpeg_destroy_decompress(&info);
        return false;
    }
    jpeg_create_decompress(&info);
    jpeg_mem_src(&info, bytes.data(), static_cast<unsigned long>(bytes.size()));
    jpeg_read_header(&info, TRUE);
    if (!checkDecodedSize(info.image_width, info.image_height, "JPEG", maxPixels).isOk()) {
        failure->kind = JpegFailure::Kind::kTooLarge;
        failure->width = info.image_width;
        failure->height = info.image_height;
        jpeg_destroy_decompress(&info);
        return false;
    }
    info.out_color_space = info.num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_start_decompress(&info);
    out->width = int(info.output_width);
    out->height = int(info.output_height);
    out->channels = int(info.output_components);
    out->bytes.resize(out->rowBytes() * size_t(out->height));
    while (info.output_scanline < info.output_height) {
        JSAMPROW row = out->bytes.data() + out->rowBytes() * info.output_scanline;
        jpeg_read_scanlines(&info, &row, 1);
    }
    jpeg_finish_decompress(&info);
    jpeg_destroy_decompress(&info);
    if (err.warning[0] != '\0') {
        failure->kind = JpegFailure::Kind::kDamaged;
        std::memcpy(failure->text, err.warning, sizeof(failure->text));
        return false;
    }
    return true;
}

std::string jpegFailureText(const JpegFailure& failure, int64_t maxPixels) {
    switch (failure.kind) {
        case JpegFailure::Kind::kTooLarge:
            return fmt::format("declares {}x{} pixels, more than the limit of {} pixels",
                               failure.width, failure.height,
                               std::min(maxPixels, kMaxDecodedPixels));
        case JpegFailure::Kind::kDamaged:
            return fmt::format("damaged data ({})", failure.text);
        case JpegFailure::Kind::kLibjpeg:
            break;
    }
    return failure.text;
}

}  // namespace

Result<ByteImage> decodeImage(std::span<const uint8_t> bytes, int64_t maxPixels) {
    static const uint8_t kPngSig[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    if (bytes.size() >= 8 && std::memcmp(bytes.data(), kPngSig, 8) == 0)
        return decodePng(bytes, maxPixels);
    if (bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF) {
        ByteImage out;
        JpegFailure failure;
        if (!decodeJpegInto(bytes, maxPixels, &out, &failure))
            return errorStatus(ErrorCode::kCorruptData,
                               "JPEG: " + jpegFailureText(failure, maxPixels));
        return out;
    }
    return errorStatus(ErrorCode::kUnsupported, "not a PNG or JPEG image (unknown signature)");
}

Result<ByteImage> readImage(const std::string& path, int64_t maxPixels) {
    auto bytes = readFileBytes(path);
    if (!bytes) return bytes.status();
    auto image = decodeImage(*bytes, maxPixels);
    if (!image) return errorStatus(image.status().code(), path + ": " + image.status().message());
    return image;
}

Result<std::vector<uint8_t>> encodePng(const ByteImage& image, int compressionLevel) {
    if (image.channels < 1 || image.channels > 4)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("cannot encode {} channels as PNG (1-4)", image.channels));
    if (image.width < 1 || image.height < 1)
        return errorStatus(ErrorCode::kInvalidArgument, "cannot encode an empty image as PNG");
    if (image.bytes.size() != image.rowBytes() * size_t(image.height))
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("{} bytes for a {}x{} image of {} channels", image.bytes.size(),
                        image.width, image.height, image.channels));
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!info) {
        png_destroy_write_struct(&png, nullptr);
        return errorStatus(ErrorCode::kInternal, "libpng could not allocate its state");
    }
    // The output vector lives outside the setjmp scope and is only appended to by the callback.
    auto* out = new std::vector<uint8_t>();
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        delete out;
        return errorStatus(ErrorCode::kInternal, "libpng failed while encoding");
    }
    png_set_write_fn(
        png, out,
        [](png_structp p, png_bytep data, png_size_t size) {
            auto* v = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(p));
            v->insert(v->end(), data, data + size);
        },
        nullptr);
    static const int kColorTypes[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                       PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGB_ALPHA};
    png_set_IHDR(png, info, png_uint_32(image.width), png_uint_32(image.height), 8,
                 kColorTypes[image.channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, std::clamp(compressionLevel, 0, 9));
    png_write_info(png, info);
    for (int y = 0; y < image.height; ++y)
        png_write_row(png, const_cast<png_bytep>(image.bytes.data() + image.rowBytes() * size_t(y)));
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    std::vector<uint8_t> result = std::move(*out);
    delete out;
    return result;
}

Status writePng(const std::string& path, const ByteImage& image, int compressionLevel) {
    auto encoded = encodePng(image, compressionLevel);
    if (!encoded) return encoded.status();
    return writeFileBytes(path, *encoded);
}

Status writePng(const std::string& path, const Image<Rgba8>& image, int compressionLevel) {
    return writePng(path, fromRgba8(image, 4), compressionLevel);
}

Result<std::vector<uint8_t>> readFileBytes(const std::string& path) {
    auto text = readFileChecked(path);
    if (!text) return text.status();
    return std::vector<uint8_t>(text->begin(), text->end());
}

Status writeFileBytes(const std::string& path, std::span<const uint8_t> bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) return errorStatus(ErrorCode::kIoError, fmt::format("cannot create '{}'", path));
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    out.close();
    if (!out) return errorStatus(ErrorCode::kIoError, fmt::format("cannot write '{}'", path));
    return Status::ok();
}

}  // namespace plx
