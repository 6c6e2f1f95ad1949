// Owning frame buffers, ID statistics and visualisations of the depth and ID targets.

#include <algorithm>
#include <cstdio>

#include <fmt/format.h>

#include <plx/raster/raster.h>

#include "pipeline.h"

namespace plx::raster {

Result<Shading> parseShading(const std::string& name) {
    if (name == "flat" || name == "constant") return Shading::kFlat;
    if (name == "gouraud") return Shading::kGouraud;
    if (name == "textured") return Shading::kTextured;
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("unknown shading '{}' (flat, gouraud, textured)", name));
}

const char* shadingName(Shading shading) {
    switch (shading) {
        case Shading::kFlat: return "flat";
        case Shading::kGouraud: return "gouraud";
        case Shading::kTextured: return "textured";
    }
    return "unknown";
}

Status checkRenderRequest(const Camera& camera, const RenderOptions& options,
                          const RenderTargets& rt) {
    auto fits = [&](int width, int height) {
        return width == camera.width() && height == camera.height();
    };
    auto bad = [](const char* what) { return errorStatus(ErrorCode::kInvalidArgument, what); };
    if (!enumWithin(options.shading, Shading::kFlat, Shading::kTextured))
        return bad("unknown shading");
    if (options.colorOnly) {
        if (!rt.color.data) return bad("a colour-only render needs a colour target");
        if (rt.visibility.depth2.data || rt.visibility.id2.data)
            return bad("a colour-only render cannot write a second depth layer");
        if (rt.visibility.unsampledVisible)
            return bad("a colour-only render cannot report unsampled triangles (no depth)");
        if (rt.visibility.tileIds) return bad("a colour-only render has no ID target to visit");
    } else if (!rt.depth.data || !rt.id.data) {
        // Tile memory stands in for the missing planes, which holds only tiles that start clear.
        if (!options.clearTargets)
            return bad("a render that keeps its targets' contents needs depth and ID targets");
        if (rt.visibility.id2.data)
            return bad("a render with a second depth layer needs depth and ID targets");
        if (rt.visibility.unsampledVisible && !rt.depth.data)
            return bad("reporting unsampled triangles needs a depth target");
    }
    if ((rt.depth.data && !fits(rt.depth.width, rt.depth.height)) ||
        (rt.id.data && !fits(rt.id.width, rt.id.height)))
        return bad("depth or ID target size differs from the camera's image");
    if (rt.color.data && !fits(rt.color.width, rt.color.height))
        return bad("colour target size differs from the camera's image");
    if ((rt.visibility.id2.data == nullptr) != (rt.visibility.depth2.data == nullptr))
        return bad("the second layer needs both its depth and its ID target");
    if (rt.visibility.id2.data && (!fits(rt.visibility.id2.width, rt.visibility.id2.height) ||
                                   !fits(rt.visibility.depth2.width, rt.visibility.depth2.height)))
        return bad("second-layer target size differs from the camera's image");
    // Rows that overlap would be written over each other, and past the view's end.
    auto rowsApart = [](const auto& view) { return !view.data || view.strideElems >= view.width; };
    if (!rowsApart(rt.color) || !rowsApart(rt.depth) || !rowsApart(rt.id) ||
        !rowsApart(rt.visibility.depth2) || !rowsApart(rt.visibility.id2))
        return bad("a target's row stride is smaller than its width");
    return Status::ok();
}

namespace detail {

void checkRenderRequestOrDie(const Camera& camera, const RenderOptions& options,
                             const RenderTargets& targets) {
    Status s = checkRenderRequest(camera, options, targets);
    if (s.isOk()) [[likely]]
        return;
    fmt::print(stderr, "raster: {}\n", s.message());
    PLX_CHECK(s.isOk());
}

}  // namespace detail

void FrameBuffers::resize(int width, int height) {
    color.resize(width, height);
    depth.resize(width, height);
    id.resize(width, height);
}

size_t countDistinctIds(const Image<uint32_t>& ids) {
    std::vector<uint32_t> values(ids.data(), ids.data() + ids.pixelCount());
    std::sort(values.begin(), values.end());
    size_t n = 0;
    for (size_t i = 0; i < values.size(); ++i)
        if (values[i] != 0 && (i == 0 || values[i] != values[i - 1])) ++n;
    return n;
}

Image<Rgba8> visualizeDepth(const Image<float>& depth) {
    float lo = INFINITY, hi = 0.0f;
    for (size_t i = 0; i < depth.pixelCount(); ++i) {
        float d = depth.data()[i];
        if (d > 0.0f) {
            lo = std::min(lo, d);
            hi = std::max(hi, d);
        }
    }
    Image<Rgba8> out(depth.width(), depth.height(), Rgba8{0, 0, 0, 255});
    if (!(hi > 0.0f)) return out;
    // Depth holds 1/z; showing it linearly in 1/z puts most grey levels close to the eye, where
    // the eye looks. Map [lo, hi] to [40, 255] so the farthest drawn surface stays visible.
    float scale = hi > lo ? 215.0f / (hi - lo) : 0.0f;
    for (size_t i = 0; i < depth.pixelCount(); ++i) {
        float d = depth.data()[i];
        if (d > 0.0f) {
            auto g = uint8_t(40.0f + (d - lo) * scale);
            out.data()[i] = {g, g, g, 255};
        }
    }
    return out;
}

Image<Rgba8> visualizeIds(const Image<uint32_t>& ids) {
    Image<Rgba8> out(ids.width(), ids.height(), Rgba8{0, 0, 0, 255});
    for (size_t i = 0; i < ids.pixelCount(); ++i) {
        uint32_t id = ids.data()[i];
        if (!id) continue;
        // Integer hash (lowbias32) so neighbouring IDs get unrelated colours.
        uint32_t h = id;
        h ^= h >> 16;
        h *= 0x7feb352dU;
        h ^= h >> 15;
        h *= 0x846ca68bU;
        h ^= h >> 16;
        out.data()[i] = {uint8_t(64 + (h & 0xBF)), uint8_t(64 + ((h >> 8) & 0xBF)),
                         uint8_t(64 + ((h >> 16) & 0xBF)), 255};
    }
    return out;
}

}  // namespace plx::raster
