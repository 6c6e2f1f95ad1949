// The reference-view and reference-set layouts (docs/remote-protocol.md): headers, camera,
// exact per-row disparity ranges, then the colour and disparity payloads (payloads.h).

#include <plx/remote/codec.h>

#include <cmath>

#include <fmt/format.h>
#include <oneapi/tbb/parallel_for.h>

#include <plx/warp/reference.h>

#include "bytes.h"
#include "payloads.h"

namespace plx::remote {
namespace {

constexpr size_t kViewHeaderBytes = 72;  // up to the row ranges
constexpr size_t kSetHeaderBytes = 44;   // up to the first view

bool knownDisparityCodec(int c) {
    return c >= int(DisparityCodec::kQuantized16) && c <= int(DisparityCodec::kQuantized16Packed);
}
// The q16 codecs share the quantisation, the range fields and the residuals.
bool isQ16(DisparityCodec c) {
    return c != DisparityCodec::kFloatZstd;
}

Status checkOptions(const CodecOptions& o) {
    if (o.color != ColorCodec::kJpeg && o.color != ColorCodec::kZstd) {
        return {ErrorCode::kInvalidArgument, "codec options: unknown colour codec"};
    }
    if (!knownDisparityCodec(int(o.disparity))) {
        return {ErrorCode::kInvalidArgument, "codec options: unknown disparity codec"};
    }
    if (o.jpegQuality < 1 || o.jpegQuality > 100) {
        return {ErrorCode::kInvalidArgument,
                fmt::format("codec options: JPEG quality {} outside 1..100", o.jpegQuality)};
    }
    if (o.zstdLevel < 1 || o.zstdLevel > 19) {
        return {ErrorCode::kInvalidArgument,
                fmt::format("codec options: zstd level {} outside 1..19", o.zstdLevel)};
    }
    if (o.deflateLevel < 1 || o.deflateLevel > 9) {
        return {ErrorCode::kInvalidArgument,
                fmt::format("codec options: deflate level {} outside 1..9", o.deflateLevel)};
    }
    return {};
}

// The first x whose value is NaN or outside [lo, hi], or w. Counted first without a branch
// (quiet comparisons, which the compiler vectorises), as a valid row has none.
int firstOutside(const float* row, int w, float lo, float hi) {
    int outside = 0;
    for (int x = 0; x < w; ++x)
        outside += int(std::isless(row[x], lo)) | int(std::isgreater(row[x], hi)) |
                   int(std::isunordered(row[x], row[x]));
    if (outside == 0) return w;
    int x = 0;
    while (row[x] >= lo && row[x] <= hi) ++x;
    return x;
}

// The view's sizes and row ranges.
Status checkViewShape(const warp::ReferenceView& v) {
    const int w = v.camera.width(), h = v.camera.height();
    if (w > 65535 || h > 65535) {
        return {ErrorCode::kInvalidArgument, fmt::format("reference view: {}x{} too large", w, h)};
    }
    if (v.color.width() != w || v.color.height() != h || v.disparity.width() != w ||
        v.disparity.height() != h || v.rowMinDisparity.size() != size_t(h) ||
        v.rowMaxDisparity.size() != size_t(h)) {
        return {ErrorCode::kInvalidArgument,
                "reference view: colour, disparity or row ranges differ from the camera's size"};
    }
    for (int y = 0; y < h; ++y) {
        const float lo = v.rowMinDisparity[size_t(y)], hi = v.rowMaxDisparity[size_t(y)];
        if (!(lo >= 0.0f && hi >= lo && std::isfinite(hi))) {
            return {
                ErrorCode::kInvalidArgument,
                fmt::format("reference view: row {} disparity range [{}, {}] invalid", y, lo, hi)};
        }
    }
    return {};
}

// Each pixel finite and within its row's range (which implies >= 0 for a valid range): what the
// decoder will hold the decoded pixels to. After checkViewShape.
Status checkViewPixels(const warp::ReferenceView& v) {
    const int w = v.camera.width();
    for (int y = 0; y < v.camera.height(); ++y) {
        const float lo = v.rowMinDisparity[size_t(y)], hi = v.rowMaxDisparity[size_t(y)];
        const int x = firstOutside(v.disparity.row(y), w, lo, hi);
        if (x < w) {
            return {ErrorCode::kInvalidArgument,
                    fmt::format("reference view: disparity {} at ({}, {}) outside its row's "
                                "range [{}, {}]",
                                v.disparity.at(x, y), x, y, lo, hi)};
        }
    }
    return {};
}

// The view checked (checkViewShape, checkViewPixels) and, for q16, its disparity range: one pass
// over the pixels for both, since a server encodes megapixels per set (the separate check took
// a fifteenth of a set's encode).
Result<DisparityRange> checkedRange(const warp::ReferenceView& v, bool q16) {
    PLX_RETURN_IF_ERROR(checkViewShape(v));
    if (!q16) {
        PLX_RETURN_IF_ERROR(checkViewPixels(v));
        return DisparityRange{};
    }
    bool inside = false;
    const DisparityRange range =
        disparityRangeInRows(v.disparity, v.rowMinDisparity, v.rowMaxDisparity, &inside);
    if (inside) return range;
    PLX_RETURN_IF_ERROR(checkViewPixels(v));  // names the pixel
    return Status(ErrorCode::kInternal, "reference view: a disparity outside its row's range");
}

void writeCamera(ByteWriter& w, const CameraDesc& d) {
    w.vec3(d.eyePos);
    w.vec3(d.targetPos);
    w.vec3(d.upDir);
    w.f32(d.fovYDegrees);
    w.f32(d.nearPlane);
    w.f32(d.farPlane);
    w.f32(d.principalShiftPx.x);
    w.f32(d.principalShiftPx.y);
}

// Appends `u32 size` then the payload.
void writeSized(ByteWriter& w, const std::vector<uint8_t>& payload) {
    w.u32(uint32_t(payload.size()));
    w.bytes(payload);
}

// Reads a view's header fields up to the row ranges: codecs, size (checked against the limits
// before anything is allocated), camera, q16 range.
struct ViewHeader {
    ColorCodec color{};
    DisparityCodec disparity{};
    CameraDesc camera;
    DisparityRange range;
};

void readVersion(ByteReader& r) {
    if (const uint8_t v = r.u8("version"); r.ok() && v != kCodecVersion) {
        r.fail(ErrorCode::kUnsupported, "codec version {} (this decoder reads {})", v,
               kCodecVersion);
    }
}

// Version, codecs and the reserved byte.
void readCodecs(ByteReader& r, ViewHeader* h) {
    readVersion(r);
    const uint8_t color = r.u8("colorCodec"), disparity = r.u8("disparityCodec");
    const uint8_t reserved = r.u8("reserved");
    if (r.ok() && color != uint8_t(ColorCodec::kJpeg) && color != uint8_t(ColorCodec::kZstd)) {
        r.fail(ErrorCode::kCorruptData, "unknown colorCodec {}", color);
    }
    if (r.ok() && !knownDisparityCodec(disparity)) {
        r.fail(ErrorCode::kCorruptData, "unknown disparityCodec {}", disparity);
    }
    if (r.ok() && reserved != 0) r.fail(ErrorCode::kCorruptData, "reserved byte is {}", reserved);
    h->color = ColorCodec(color);
    h->disparity = DisparityCodec(disparity);
}

// Size (against the limits) and the camera's fields; Camera::create checks the rest.
void readCamera(ByteReader& r, const DecodeLimits& limits, CameraDesc* c) {
    c->width = r.u16("width");
    c->height = r.u16("height");
    if (r.ok() &&
        (c->width < 1 || c->height < 1 || c->width > limits.maxViewSide ||
         c->height > limits.maxViewSide || int64_t(c->width) * c->height > limits.maxViewPixels)) {
        r.fail(ErrorCode::kOutOfRange, "size {}x{} outside 1..{} a side and {} pixels", c->width,
               c->height, limits.maxViewSide, limits.maxViewPixels);
    }
    c->eyePos = r.vec3("eyePos");
    c->targetPos = r.vec3("targetPos");
    c->upDir = r.vec3("upDir");
    c->fovYDegrees = r.f32("fovYDegrees");
    c->nearPlane = r.f32("nearPlane");
    c->farPlane = r.f32("farPlane");
    c->principalShiftPx.x = r.f32("principalShiftPx");
    c->principalShiftPx.y = r.f32("principalShiftPx");
}

// The q16 range: 0 < dmin <= dmax, or both 0 (nothing drawn); both 0 for the raw codec.
void readDisparityRange(ByteReader& r, DisparityCodec codec, DisparityRange* range) {
    range->dmin = r.f32("dmin");
    range->dmax = r.f32("dmax");
    const bool empty = range->dmin == 0.0f && range->dmax == 0.0f;
    const bool valid = isQ16(codec)
                           ? empty || (range->dmin > 0.0f && range->dmax >= range->dmin)
                           : empty;
    if (r.ok() && !valid) {
        r.fail(ErrorCode::kCorruptData, "disparity range [{}, {}] invalid for its codec",
               range->dmin, range->dmax);
    }
}

// A disparity payload's framing and recorded sizes against the view's, without decompressing.
Status checkDisparityHeader(const ViewHeader& h, std::span<const uint8_t> payload, size_t pixels) {
    switch (h.disparity) {
        case DisparityCodec::kQuantized16Deflate:
            return checkZlibHeader(payload, "disparity");
        case DisparityCodec::kQuantized16Packed:
            return packedEscapeCount(payload, h.camera.width, h.camera.height).status();
        case DisparityCodec::kQuantized16:
            return checkZstdFrame(payload, pixels * 2, "disparity");
        case DisparityCodec::kFloatZstd:
            break;
    }
    return checkZstdFrame(payload, pixels * 4, "disparity");
}

ViewHeader readViewHeader(ByteReader& r, const DecodeLimits& limits) {
    ViewHeader h;
    readCodecs(r, &h);
    readCamera(r, limits, &h.camera);
    readDisparityRange(r, h.disparity, &h.range);
    return h;
}

// Reads the per-row ranges: finite, 0 <= min <= max.
void readRowRanges(ByteReader& r, int height, warp::ReferenceView* out) {
    if (r.ok() && r.left() < size_t(height) * 8) {
        r.fail(ErrorCode::kCorruptData, "truncated at row ranges (need {} bytes, {} left)",
               size_t(height) * 8, r.left());
    }
    if (!r.ok()) return;
    out->rowMinDisparity.resize(size_t(height));
    out->rowMaxDisparity.resize(size_t(height));
    for (float& v : out->rowMinDisparity) v = r.f32("rowMinDisparity");
    for (float& v : out->rowMaxDisparity) v = r.f32("rowMaxDisparity");
    for (int y = 0; y < height && r.ok(); ++y) {
        const float lo = out->rowMinDisparity[size_t(y)], hi = out->rowMaxDisparity[size_t(y)];
        if (!(lo >= 0.0f && hi >= lo)) {
            r.fail(ErrorCode::kCorruptData, "row {} disparity range [{}, {}] invalid", y, lo, hi);
        }
    }
}

// A `u32 size` then that many bytes; the size must be >= 1 and within what is left.
std::span<const uint8_t> readSized(ByteReader& r, const char* field) {
    const uint32_t n = r.u32(field);
    if (r.ok() && (n == 0 || n > r.left())) {
        r.fail(ErrorCode::kCorruptData, "{} {} past the end ({} left)", field, n, r.left());
    }
    return r.bytes(field, n);
}

Status withContext(const Status& s, const std::string& context) {
    return s.isOk() ? s : Status(s.code(), context + ": " + s.message());
}

// The set's fixed header: version, view count, pose and render time; returns the view count.
int readSetHeader(ByteReader& r, const DecodeLimits& limits, warp::ReferenceSet* header) {
    readVersion(r);
    const int count = r.u8("viewCount");
    const int maxViews = std::min(6, limits.maxViews);
    if (r.ok() && (count < 1 || count > maxViews)) {
        r.fail(ErrorCode::kOutOfRange, "viewCount {} outside 1..{}", count, maxViews);
    }
    if (const uint16_t reserved = r.u16("reserved"); r.ok() && reserved != 0) {
        r.fail(ErrorCode::kCorruptData, "reserved field is {}", reserved);
    }
    header->pose.eye = r.vec3("eye");
    header->pose.forward = r.vec3("forward");
    header->pose.up = r.vec3("up");
    const float renderMs = r.f32("renderMs");
    if (r.ok() && !(renderMs >= 0.0f && renderMs < 1e6f)) {
        r.fail(ErrorCode::kCorruptData, "renderMs {} outside [0, 1e6)", renderMs);
    }
    header->renderMs = renderMs;
    return count;
}

// Every view's bytes, read before any is decoded so that the set's pixel budget (from the views'
// width and height fields) is checked before the bulk of the allocation.
std::vector<std::span<const uint8_t>> readViewSpans(ByteReader& r, int count,
                                                    const DecodeLimits& limits) {
    std::vector<std::span<const uint8_t>> views;
    int64_t pixels = 0;
    for (int i = 0; i < count && r.ok(); ++i) {
        views.push_back(readSized(r, "viewBytes"));
        if (r.ok() && views.back().size() >= 8) {
            const auto& v = views.back();
            pixels += int64_t(v[4] | (v[5] << 8)) * int64_t(v[6] | (v[7] << 8));
        }
    }
    r.expectEnd();
    if (r.ok() && pixels > limits.maxSetPixels) {
        r.fail(ErrorCode::kOutOfRange, "{} pixels over the limit {}", pixels, limits.maxSetPixels);
    }
    return views;
}

}  // namespace

float disparityErrorBound(const Image<float>& disparity) {
    const DisparityRange r = disparityRange(disparity);
    if (r.dmax == 0.0f) return 0.0f;
    return float((double(r.dmax) - double(r.dmin)) / 65534.0 / 2.0 +
                 std::ldexp(double(r.dmax), -24));
}

Result<std::vector<uint8_t>> encodeReferenceView(const warp::ReferenceView& view,
                                                 const CodecOptions& options) {
    PLX_RETURN_IF_ERROR(checkOptions(options));
    const bool q16 = isQ16(options.disparity);
    const Result<DisparityRange> checked = checkedRange(view, q16);
    if (!checked) return checked.status();
    const DisparityRange range = *checked;
    std::vector<uint8_t> color, disparity;
    PLX_RETURN_IF_ERROR(encodeColor(view.color, options, &color));
    const int level = options.disparity == DisparityCodec::kQuantized16Deflate
                          ? options.deflateLevel
                          : options.zstdLevel;
    PLX_RETURN_IF_ERROR(
        q16 ? encodeDisparityQ16(view.disparity, range, options.disparity, level, &disparity)
            : encodeDisparityRaw(view.disparity, options.zstdLevel, &disparity));
    std::vector<uint8_t> out;
    out.reserve(kViewHeaderBytes + view.rowMinDisparity.size() * 8 + 8 + color.size() +
                disparity.size());
    ByteWriter w(&out);
    w.u8(kCodecVersion);
    w.u8(uint8_t(options.color));
    w.u8(uint8_t(options.disparity));
    w.u8(0);
    w.u16(uint16_t(view.camera.width()));
    w.u16(uint16_t(view.camera.height()));
    writeCamera(w, view.camera.desc());
    w.f32(range.dmin);
    w.f32(range.dmax);
    for (float v : view.rowMinDisparity) w.f32(v);
    for (float v : view.rowMaxDisparity) w.f32(v);
    writeSized(w, color);
    writeSized(w, disparity);
    return out;
}

Status decodeReferenceView(std::span<const uint8_t> bytes, const DecodeLimits& limits,
                           warp::ReferenceView* out) {
    ByteReader r(bytes, "reference view");
    const ViewHeader h = readViewHeader(r, limits);
    if (!r.ok()) return r.status();
    Result<Camera> camera = Camera::create(h.camera);
    if (!camera) return withContext(camera.status(), "reference view: camera");
    readRowRanges(r, h.camera.height, out);
    const std::span<const uint8_t> color = readSized(r, "colorBytes");
    const std::span<const uint8_t> disparity = readSized(r, "disparityBytes");
    r.expectEnd();
    if (!r.ok()) return r.status();
    // The payloads' own headers agree with the view's size before the images are allocated.
    const size_t pixels = size_t(h.camera.width) * size_t(h.camera.height);
    PLX_RETURN_IF_ERROR(withContext(
        checkColorHeader(h.color, color, h.camera.width, h.camera.height), "reference view"));
    PLX_RETURN_IF_ERROR(withContext(checkDisparityHeader(h, disparity, pixels), "reference view"));
    out->camera = *camera;
    // The decoders below write every pixel (or the view is refused), so buffers of the right size
    // (a spare set's) are kept as they are: clearing them was 50 MB of stores per set of 1248-px
    // faces.
    if (out->color.width() != h.camera.width || out->color.height() != h.camera.height)
        out->color.resize(h.camera.width, h.camera.height);
    if (out->disparity.width() != h.camera.width || out->disparity.height() != h.camera.height)
        out->disparity.resize(h.camera.width, h.camera.height);
    PLX_RETURN_IF_ERROR(withContext(decodeColor(h.color, color, &out->color), "reference view"));
    const Status s = isQ16(h.disparity)
                         ? decodeDisparityQ16(disparity, h.disparity, h.range, out->rowMinDisparity,
                                              out->rowMaxDisparity, &out->disparity)
                         : decodeDisparityRaw(disparity, out->rowMinDisparity, out->rowMaxDisparity,
                                              &out->disparity);
    return withContext(s, "reference view");
}

Result<std::vector<uint8_t>> encodeReferenceSet(const warp::ReferenceSet& set,
                                                const CodecOptions& options) {
    if (set.views.empty() || set.views.size() > 255) {
        return Status(ErrorCode::kInvalidArgument,
                      fmt::format("reference set: {} views (1..255)", set.views.size()));
    }
    PLX_RETURN_IF_ERROR(warp::checkPose(set.pose));
    std::vector<uint8_t> out;
    ByteWriter w(&out);
    w.u8(kCodecVersion);
    w.u8(uint8_t(set.views.size()));
    w.u16(0);
    w.vec3(set.pose.eye);
    w.vec3(set.pose.forward);
    w.vec3(set.pose.up);
    w.f32(std::isfinite(set.renderMs) ? float(std::clamp(set.renderMs, 0.0, 999999.0)) : 0.0f);
    // The views are independent: each is coded on its own TBB task (in the caller's arena, so a
    // ThreadPool bounds it), then written in order, so the bytes do not depend on the schedule.
    std::vector<Result<std::vector<uint8_t>>> views(set.views.size(), std::vector<uint8_t>{});
    tbb::parallel_for(size_t(0), set.views.size(), [&](size_t i) {
        views[i] = encodeReferenceView(set.views[i], options);
    });
    for (const Result<std::vector<uint8_t>>& view : views) {
        if (!view) return view.status();
        writeSized(w, *view);
    }
    return out;
}

Status decodeReferenceSet(std::span<const uint8_t> bytes, const DecodeLimits& limits,
                          warp::ReferenceSet* out) {
    ByteReader r(bytes, "reference set");
    warp::ReferenceSet header;
    const int count = readSetHeader(r, limits, &header);
    if (!r.ok()) return r.status();
    if (Status s = warp::checkPose(header.pose); !s.isOk()) return withContext(s, "reference set");
    const std::vector<std::span<const uint8_t>> views = readViewSpans(r, count, limits);
    if (!r.ok()) return r.status();
    out->pose = header.pose;
    out->renderMs = header.renderMs;
    out->views.resize(size_t(count));
    // One task per view, as in encodeReferenceSet; the first failing view (in order) is reported.
    std::vector<Status> statuses(static_cast<size_t>(count));
    tbb::parallel_for(size_t(0), size_t(count), [&](size_t i) {
        statuses[i] = decodeReferenceView(views[i], limits, &out->views[i]);
    });
    for (size_t i = 0; i < statuses.size(); ++i) {
        if (!statuses[i].isOk())
            return withContext(statuses[i], fmt::format("reference set: view {}", i));
    }
    return {};
}

}  // namespace plx::remote
