// Writes the scene database (docs/stream-format.md) and joins range builds.

#include <filesystem>
#include <system_error>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <plx/core/image_io.h>
#include <plx/ptm/encoder.h>
#include <plx/stream/database.h>

#include "glb_writer.h"

namespace plx::stream {
namespace fs = std::filesystem;
namespace {

std::span<const uint8_t> asBytes(const std::string& s) {
    return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

// The texture's base level as PTM (docs/stream-format.md, "Textures"): RGB unless some texel
// is translucent, every level down to 1x1.
Result<std::vector<uint8_t>> encodeTexture(const scene::Texture& texture) {
    if (texture.mips.empty())
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("texture '{}' has no image", texture.name));
    const Image<Rgba8>& base = texture.mips[0];
    bool alpha = false;
    for (int y = 0; y < base.height() && !alpha; ++y)
        for (int x = 0; x < base.width(); ++x) alpha = alpha || base.at(x, y).a != 255;
    auto bytes = ptm::encode(fromRgba8(base, alpha ? 4 : 3));
    if (!bytes)
        return errorStatus(bytes.status().code(),
                           fmt::format("texture '{}': {}", texture.name, bytes.status().message()));
    return bytes;
}

// The cell file of cell c, its geometry and texture sizes already known.
CellFile makeCellFile(const scene::Scene& scene, const Cells& cells, const CellVisibility& vis,
                      const std::vector<uint32_t>& adjacent, const std::vector<uint32_t>& triangles,
                      uint64_t geometryBytes, const std::vector<std::vector<uint8_t>>& ptms,
                      const VisibilityConfig& sampling) {
    CellFile cell;
    cell.index = vis.cell;
    cell.hullMin = cells.boxes[vis.cell].lo;
    cell.hullMax = cells.boxes[vis.cell].hi;
    cell.geometry = {geometryUrl(vis.cell), geometryBytes};
    cell.triangles = triangles.size();
    std::vector<bool> used(scene.textures.size(), false);
    for (uint32_t t : triangles) {
        int tex = scene.materials[size_t(scene.meshes[scene.meshOfTriangle(t)].materialIndex)]
                      .baseColorTexture;
        if (tex >= 0) used[size_t(tex)] = true;
    }
    // Texture URLs are zero-padded, so index order is URL order.
    for (size_t k = 0; k < used.size(); ++k)
        if (used[k]) cell.textures.push_back({textureUrl(uint32_t(k)), ptms[k].size()});
    for (uint32_t a : adjacent) cell.adjacent.push_back(cellUrl(a));
    for (const PvsEntry& e : pvsWithAch(vis)) {
        cell.pvs.push_back({cellUrl(e.cell), e.pixels, e.ach});
        cell.totalPixels += e.pixels;
    }
    cell.textureCoverage = vis.textures;
    cell.samples = sampling.samples;
    cell.faceSize = sampling.faceSize;
    return cell;
}

RootFile makeRoot(const scene::Scene& scene, const Cells& cells, const std::string& sceneName) {
    RootFile root;
    root.scene = sceneName.substr(0, 256);
    root.boundsMin = scene.bounds().lo;
    root.boundsMax = scene.bounds().hi;
    root.cells = uint32_t(cells.boxes.size());
    root.textures = uint32_t(scene.textures.size());
    std::vector<scene::Viewpoint> viewpoints = scene.viewpoints;
    if (viewpoints.empty()) viewpoints.push_back(scene::defaultViewpoint(scene));
    for (const scene::Viewpoint& v : viewpoints) {
        if (root.viewpoints.size() == size_t(kMaxViewpoints)) break;
        root.viewpoints.push_back({v.name.empty() ? "default" : v.name.substr(0, 64), v.eyePos,
                                   v.targetPos, v.upDir, v.fovYDegrees,
                                   cellUrl(cellOfPoint(cells.boxes, v.eyePos))});
    }
    return root;
}

}  // namespace

Status writeBelow(const std::string& dir, const std::string& relative,
                  std::span<const uint8_t> bytes) {
    PLX_RETURN_IF_ERROR(checkUrl(relative));
    const fs::path path = fs::path(dir) / relative;
    // Refuse a symbolic link anywhere below dir: it could point outside.
    std::error_code ec;
    for (fs::path p = path; p != fs::path(dir) && p.has_relative_path(); p = p.parent_path())
        if (fs::is_symlink(fs::symlink_status(p, ec)))
            return errorStatus(ErrorCode::kIoError,
                               fmt::format("{}: a symbolic link, not written through", p.string()));
    fs::create_directories(path.parent_path(), ec);
    if (ec)
        return errorStatus(
            ErrorCode::kIoError,
            fmt::format("cannot create {}: {}", path.parent_path().string(), ec.message()));
    return writeFileBytes(path.string(), bytes);
}

std::string sceneHash(const scene::Scene& scene, const Cells& cells) {
    uint64_t h = 0xcbf29ce484222325ULL;
    auto add = [&](const void* data, size_t n) {
        const auto* p = static_cast<const uint8_t*>(data);
        for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ULL;
    };
    for (const scene::Mesh& m : scene.meshes) {
        add(m.positions.data(), m.positions.size() * sizeof(Vec3));
        add(m.indices.data(), m.indices.size() * sizeof(uint32_t));
    }
    add(cells.boxes.data(), cells.boxes.size() * sizeof(Aabb));
    return fmt::format("{:016x}", h);
}

Result<BuildStats> writeDatabase(const scene::Scene& scene, const Cells& cells,
                                 const std::vector<CellVisibility>& visibility,
                                 const VisibilityConfig& sampling, const std::string& sceneName,
                                 const std::string& dir) {
    const size_t cellCount = cells.boxes.size();
    if (visibility.size() != cellCount)
        return errorStatus(ErrorCode::kInvalidArgument, "visibility does not cover every cell");
    for (size_t c = 0; c < cellCount; ++c) {
        if (visibility[c].cell != c)
            return errorStatus(ErrorCode::kInvalidArgument, "visibility out of cell order");
        if (!visibility[c].textures.empty() &&
            visibility[c].textures.back().first >= scene.textures.size())
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("visibility of cell {} names texture {} of {}", c,
                                           visibility[c].textures.back().first,
                                           scene.textures.size()));
    }
    if (scene.textures.size() > size_t(kMaxTextures))
        return errorStatus(
            ErrorCode::kOutOfRange,
            fmt::format("{} textures, more than {}", scene.textures.size(), kMaxTextures));
    // Textures and cell geometry are independent: encode them in parallel, write in order.
    std::vector<Result<std::vector<uint8_t>>> ptms(scene.textures.size(),
                                                   Status(ErrorCode::kInternal, "not encoded"));
    tbb::parallel_for(size_t(0), ptms.size(),
                      [&](size_t k) { ptms[k] = encodeTexture(scene.textures[k]); });
    std::vector<std::vector<uint8_t>> ptmBytes;
    for (auto& p : ptms) {
        if (!p) return p.status();
        ptmBytes.push_back(std::move(p).value());
    }
    std::vector<std::vector<uint32_t>> triangles(cellCount);
    for (uint32_t t = 0; t < uint32_t(scene.triangleCount()); ++t)
        triangles[cells.cellOfTriangle[t]].push_back(t);
    std::vector<std::vector<uint8_t>> glbs(cellCount);
    tbb::parallel_for(size_t(0), cellCount, [&](size_t c) {
        glbs[c] =
            writeCellGlb(scene, triangles[c], [](int tex) { return textureUrl(uint32_t(tex)); });
    });
    const auto adjacent = adjacentCells(cells.boxes);
    BuildStats stats;
    stats.cells = cellCount;
    stats.textures = ptmBytes.size();
    for (size_t k = 0; k < ptmBytes.size(); ++k) {
        PLX_RETURN_IF_ERROR(writeBelow(dir, textureUrl(uint32_t(k)), ptmBytes[k]));
        stats.textureBytes += ptmBytes[k].size();
    }
    for (size_t c = 0; c < cellCount; ++c) {
        PLX_RETURN_IF_ERROR(writeBelow(dir, geometryUrl(uint32_t(c)), glbs[c]));
        std::string text =
            serializeCell(makeCellFile(scene, cells, visibility[c], adjacent[c], triangles[c],
                                       glbs[c].size(), ptmBytes, sampling));
        PLX_RETURN_IF_ERROR(writeBelow(dir, cellUrl(uint32_t(c)), asBytes(text)));
        stats.geometryBytes += glbs[c].size();
        stats.bytes += text.size();
    }
    std::string root = serializeRoot(makeRoot(scene, cells, sceneName));
    PLX_RETURN_IF_ERROR(writeBelow(dir, "root.json", asBytes(root)));
    stats.bytes += root.size() + stats.textureBytes + stats.geometryBytes;
    return stats;
}

Result<std::vector<CellVisibility>> mergeParts(const std::vector<PartFile>& parts,
                                               const std::string& hash, uint32_t cellCount) {
    if (cellCount < 1 || cellCount > uint32_t(kMaxCells))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("{} cells outside 1..{}", cellCount, kMaxCells));
    std::vector<CellVisibility> all(cellCount);
    std::vector<bool> covered(cellCount, false);
    for (size_t i = 0; i < parts.size(); ++i) {
        const PartFile& p = parts[i];
        if (p.sceneHash != hash || p.cells != cellCount)
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("part {} ({}-{}) was computed for another scene or "
                                           "cell rule",
                                           i + 1, p.first, p.last));
        if (p.samples != parts[0].samples || p.faceSize != parts[0].faceSize)
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("part {} ({}-{}) used other sampling ({} samples, "
                                           "face {}) than part 1",
                                           i + 1, p.first, p.last, p.samples, p.faceSize));
        for (const CellVisibility& v : p.visibility) {
            if (v.cell >= cellCount)
                return errorStatus(
                    ErrorCode::kInvalidArgument,
                    fmt::format("part {} names cell {} of {}", i + 1, v.cell, cellCount));
            if (covered[v.cell])
                return errorStatus(ErrorCode::kInvalidArgument,
                                   fmt::format("cell {} is in more than one part", v.cell));
            covered[v.cell] = true;
            all[v.cell] = v;
        }
    }
    for (uint32_t c = 0; c < cellCount; ++c)
        if (!covered[c])
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("no part holds cell {}", c));
    return all;
}

}  // namespace plx::stream
