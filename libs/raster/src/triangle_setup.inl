// Triangle setup and shading, compiled once per ISA (plx_add_isa_kernels): the tile kernel
// calls its own path's copy per triangle and per shaded sample; the scalar reference renderer
// calls the scalar copy. fp-contract=off in every unit keeps the results identical.

#include <algorithm>
#include <cstring>

#include "pipeline.h"

namespace plx::raster::detail::PLX_ISA_NS {

bool setupTriangle(const scene::Scene& scene, size_t meshIndex, uint32_t localTri,
                   const RasterVertex vin[3], const Viewport& vp, const ShadeContext& ctx,
                   TriangleSetup* t) {
    TriangleBox box;
    if (!triangleBox(vin[0], vin[1], vin[2], vp, ctx.cullBackFaces, &box)) return false;
    setTriangleIdentity(scene, meshIndex, localTri, t);
    setupTriangleInBox(scene, meshIndex, localTri, vin, box, ctx, t);
    return true;
}

void setupTriangleInBox(const scene::Scene& scene, size_t meshIndex, uint32_t localTri,
                        const RasterVertex vin[3], const TriangleBox& box,
                        const ShadeContext& ctx, TriangleSetup* t) {
    t->minX = box.minX;
    t->minY = box.minY;
    t->maxX = box.maxX;
    t->maxY = box.maxY;
    t->extentX = box.extentX;
    t->extentY = box.extentY;
    const RasterVertex* v[3];
    const int64_t area2 = orientPositive(vin, box.area2, v);
    t->area2 = area2;
    for (int i = 0; i < 3; ++i) {
        t->x[i] = v[i]->x;
        t->y[i] = v[i]->y;
        t->invW[i] = v[i]->invW;
    }
    // Top-left rule; edge i runs from vertex i to vertex i+1.
    for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        t->edgeBias[i] = topLeftBias(t->x[j] - t->x[i], t->y[j] - t->y[i]);
    }
    t->invArea = 1.0f / float(area2);
    t->stepB1 = float(-int64_t(t->y[0] - t->y[2]) * kSubPixelScale) * t->invArea;
    t->stepB2 = float(-int64_t(t->y[1] - t->y[0]) * kSubPixelScale) * t->invArea;

    t->texture = nullptr;
    if (ctx.shading == Shading::kFlat) return;
    const scene::Mesh& mesh = scene.meshes[meshIndex];
    const scene::Material& mat = scene.materials[size_t(mesh.materialIndex)];
    const uint32_t* idx = &mesh.indices[size_t(localTri) * 3];
    Vec3 base(mat.baseColor);
    // Per original vertex: lit colour and UV; clipped vertices blend them with their weights.
    Vec3 litColor[3];
    Vec2 uv[3];
    for (int k = 0; k < 3; ++k) {
        float light = ctx.lit ? lambert(mesh.normals[idx[k]], ctx) : 1.0f;
        litColor[k] = base * light;
        uv[k] = mesh.uvs.empty() ? Vec2(0.0f) : mesh.uvs[idx[k]];
    }
    for (int i = 0; i < 3; ++i) {
        const Vec3& w = v[i]->bary;
        t->color[i] = w.x * litColor[0] + w.y * litColor[1] + w.z * litColor[2];
        t->uv[i] = w.x * uv[0] + w.y * uv[1] + w.z * uv[2];
    }
    if (ctx.shading == Shading::kTextured && mat.baseColorTexture >= 0 && !mesh.uvs.empty())
        t->texture = &scene.textures[size_t(mat.baseColorTexture)];
    // b1 = E(2->0)/area2, b2 = E(0->1)/area2; their per-pixel derivatives for texture LOD.
    float inv = float(kSubPixelScale) / float(area2);
    t->b1dx = -float(t->y[0] - t->y[2]) * inv;
    t->b1dy = float(t->x[0] - t->x[2]) * inv;
    t->b2dx = -float(t->y[1] - t->y[0]) * inv;
    t->b2dy = float(t->x[1] - t->x[0]) * inv;
}

namespace {

// Bilinear sample of one mip level with wrap-around addressing, in linear RGB.
Vec3 sampleBilinear(const Image<Rgba8>& level, float u, float v) {
    const float* decode = srgbDecodeTable();
    float fx = u * float(level.width()) - 0.5f, fy = v * float(level.height()) - 0.5f;
    float flx = std::floor(fx), fly = std::floor(fy);
    float ax = fx - flx, ay = fy - fly;
    int w = level.width(), h = level.height();
    int32_t x0, x1, y0, y1;
    if (flx >= 0.0f && flx < float(w - 1) && fly >= 0.0f && fly < float(h - 1)) {
        // All four texels inside the level (uv away from the border, the common case): the
        // wrap below would return them unchanged, so skip its divisions. NaN fails the tests.
        x0 = int32_t(flx), y0 = int32_t(fly);
        x1 = x0 + 1, y1 = y0 + 1;
    } else {
        wrapTexels(flx, w, &x0, &x1);
        wrapTexels(fly, h, &y0, &y1);
    }
    const Rgba8* row0 = level.row(y0);
    const Rgba8* row1 = level.row(y1);
    auto texel = [&](const Rgba8* row, int x) {
        Rgba8 c = row[x];
        return Vec3(decode[c.r], decode[c.g], decode[c.b]);
    };
    Vec3 top = texel(row0, x0) * (1.0f - ax) + texel(row0, x1) * ax;
    Vec3 bottom = texel(row1, x0) * (1.0f - ax) + texel(row1, x1) * ax;
    return top * (1.0f - ay) + bottom * ay;
}

}  // namespace

Rgba8 shadeSample(const TriangleSetup& t, const ShadeContext& ctx, float b1, float b2,
                  float invW) {
    if (ctx.shading == Shading::kFlat) return flatColorFor(t, ctx);
    // Perspective-correct weights: attribute/w is affine in screen space, so the weight of
    // vertex i is b_i * invW_i / invW.
    float w = 1.0f / invW;
    float p1 = b1 * t.invW[1] * w, p2 = b2 * t.invW[2] * w, p0 = 1.0f - p1 - p2;
    Vec3 color = p0 * t.color[0] + p1 * t.color[1] + p2 * t.color[2];
    if (t.texture && t.texture->mips.size() == 1) {
        // Base level only (e.g. a render target re-used as a texture): no LOD to choose.
        Vec2 uv = p0 * t.uv[0] + p1 * t.uv[1] + p2 * t.uv[2];
        color *= sampleBilinear(t.texture->mips[0], uv.x, uv.y);
    } else if (t.texture) {
        Vec2 uv = p0 * t.uv[0] + p1 * t.uv[1] + p2 * t.uv[2];
        // Texture LOD from the analytic screen derivatives of uv = (sum b_i uv_i/w_i) / invW.
        float dInvWdx = t.b1dx * (t.invW[1] - t.invW[0]) + t.b2dx * (t.invW[2] - t.invW[0]);
        float dInvWdy = t.b1dy * (t.invW[1] - t.invW[0]) + t.b2dy * (t.invW[2] - t.invW[0]);
        Vec2 q0 = t.uv[0] * t.invW[0], q1 = t.uv[1] * t.invW[1], q2 = t.uv[2] * t.invW[2];
        Vec2 dQdx = t.b1dx * (q1 - q0) + t.b2dx * (q2 - q0);
        Vec2 dQdy = t.b1dy * (q1 - q0) + t.b2dy * (q2 - q0);
        Vec2 dUVdx = (dQdx - uv * dInvWdx) * w, dUVdy = (dQdy - uv * dInvWdy) * w;
        const Image<Rgba8>& base = t.texture->mips[0];
        Vec2 size(float(base.width()), float(base.height()));
        float rho2 =
            std::max(glm::dot(dUVdx * size, dUVdx * size), glm::dot(dUVdy * size, dUVdy * size));
        // Nearest mip level: log2(rho) = 0.5 * log2(rho^2), rounded.
        int level = 0;
        if (rho2 > 1.0f && std::isfinite(rho2))
            level =
                std::min(int(std::lround(0.5f * std::log2(rho2))), int(t.texture->mips.size()) - 1);
        color *= sampleBilinear(t.texture->mips[size_t(level)], uv.x, uv.y);
    }
    return encodeRgb(color);
}

}  // namespace plx::raster::detail::PLX_ISA_NS
