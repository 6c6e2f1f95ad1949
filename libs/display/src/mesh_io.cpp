// Warp mesh interchange: Bourke mesh-warp text, OBJ, PFM warp maps.

#include <plx/display/mesh_io.h>

#include <cmath>
#include <limits>
#include <sstream>

#include <fmt/format.h>

namespace plx::display {
namespace {

// Barycentric coordinates of p in triangle (a, b, c); false when degenerate.
bool barycentric(const DVec2& p, const DVec2& a, const DVec2& b, const DVec2& c, DVec3* w) {
    double det = (b.y - c.y) * (a.x - c.x) + (c.x - b.x) * (a.y - c.y);
    if (std::fabs(det) < 1e-300) return false;
    double w0 = ((b.y - c.y) * (p.x - c.x) + (c.x - b.x) * (p.y - c.y)) / det;
    double w1 = ((c.y - a.y) * (p.x - c.x) + (a.x - c.x) * (p.y - c.y)) / det;
    *w = {w0, w1, 1.0 - w0 - w1};
    return true;
}

DVec2 normalisedFromDisplay(const Display& d, const DVec2& p) {
    return (p - d.displayMin) / (d.displayMax - d.displayMin);
}

}  // namespace

WarpGrid resampleToGrid(const WarpMesh& mesh, int level) {
    PLX_CHECK(level >= 1 && level <= std::max(mesh.gridLevel, 1));
    WarpGrid g;
    g.nx = g.ny = (1 << level) + 1;
    size_t n = size_t(g.nx) * g.ny;
    g.displayPos.assign(n, DVec2(0.0));
    g.uvs.resize(n);
    g.intensity.assign(n, -1.0f);
    double scale = double(g.nx - 1);
    for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x) g.uvs[size_t(y) * g.nx + x] = {x / scale, y / scale};
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        const uint32_t* idx = &mesh.indices[3 * t];
        DVec2 a = mesh.uvs[idx[0]], b = mesh.uvs[idx[1]], c = mesh.uvs[idx[2]];
        DVec2 lo = glm::min(a, glm::min(b, c)) * scale, hi = glm::max(a, glm::max(b, c)) * scale;
        for (int y = int(std::ceil(lo.y - 1e-9)); y <= int(std::floor(hi.y + 1e-9)); ++y) {
            for (int x = int(std::ceil(lo.x - 1e-9)); x <= int(std::floor(hi.x + 1e-9)); ++x) {
                size_t v = size_t(y) * g.nx + x;
                if (g.intensity[v] >= 0.0f) continue;
                DVec3 w;
                if (!barycentric(g.uvs[v], a, b, c, &w)) continue;
                if (w.x < -1e-9 || w.y < -1e-9 || w.z < -1e-9) continue;
                g.displayPos[v] = w.x * mesh.displayPos[idx[0]] + w.y * mesh.displayPos[idx[1]] +
                                  w.z * mesh.displayPos[idx[2]];
                g.intensity[v] = 1.0f;
            }
        }
    }
    return g;
}

std::string formatBourke(const Display& display, const WarpGrid& grid) {
    double aspect = double(display.framebufferWidth) / display.framebufferHeight;
    std::string out = fmt::format("2\n{} {}\n", grid.nx, grid.ny);
    for (size_t v = 0; v < grid.uvs.size(); ++v) {
        DVec2 n = normalisedFromDisplay(display, grid.displayPos[v]);
        out += fmt::format("{:.9g} {:.9g} {:.9g} {:.9g} {:.9g}\n", (2.0 * n.x - 1.0) * aspect,
                           1.0 - 2.0 * n.y, grid.uvs[v].x, 1.0 - grid.uvs[v].y,
                           grid.intensity[v]);
    }
    return out;
}

Result<WarpGrid> parseBourke(const Display& display, const std::string& text) {
    auto bad = [](int line, const std::string& m) {
        return errorStatus(ErrorCode::kCorruptData, fmt::format("bourke mesh line {}: {}", line, m));
    };
    std::istringstream in(text);
    std::string line;
    int lineNo = 0;
    auto nextLine = [&]() -> bool {
        while (std::getline(in, line)) {
            ++lineNo;
            if (line.find_first_not_of(" \t\r") != std::string::npos) return true;
        }
        return false;
    };
    if (!nextLine()) return bad(1, "empty file");
    int type = 0;
    if (std::sscanf(line.c_str(), "%d", &type) != 1 || (type != 1 && type != 2))
        return bad(lineNo, "mesh type must be 1 or 2");
    WarpGrid g;
    if (!nextLine() || std::sscanf(line.c_str(), "%d %d", &g.nx, &g.ny) != 2)
        return bad(lineNo, "expected 'nx ny'");
    if (g.nx < 2 || g.ny < 2 || int64_t(g.nx) * g.ny > (int64_t(1) << 24))
        return bad(lineNo, "grid size out of range (2 .. 16M nodes)");
    double aspect = double(display.framebufferWidth) / display.framebufferHeight;
    size_t n = size_t(g.nx) * g.ny;
    g.displayPos.resize(n), g.uvs.resize(n), g.intensity.resize(n);
    for (size_t v = 0; v < n; ++v) {
        double x, y, u, t, i;
        if (!nextLine()) return bad(lineNo + 1, fmt::format("missing node {} of {}", v + 1, n));
        if (std::sscanf(line.c_str(), "%lf %lf %lf %lf %lf", &x, &y, &u, &t, &i) != 5)
            return bad(lineNo, "expected 'x y u v i'");
        if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(u) || !std::isfinite(t) ||
            !std::isfinite(i))
            return bad(lineNo, "values must be finite");
        DVec2 norm((x / aspect + 1.0) * 0.5, (1.0 - y) * 0.5);
        g.displayPos[v] = display.displayMin + norm * (display.displayMax - display.displayMin);
        g.uvs[v] = {u, 1.0 - t};
        g.intensity[v] = float(i);
    }
    return g;
}

WarpMesh meshFromGrid(const WarpGrid& grid) {
    WarpMesh m;
    m.gridLevel = -1;  // not a quadtree matrix
    m.uvs = grid.uvs;
    m.displayPos = grid.displayPos;
    for (int y = 0; y + 1 < grid.ny; ++y) {
        for (int x = 0; x + 1 < grid.nx; ++x) {
            uint32_t a = uint32_t(y * grid.nx + x), b = a + 1, c = a + uint32_t(grid.nx), d = c + 1;
            if (grid.intensity[a] < 0 || grid.intensity[b] < 0 || grid.intensity[c] < 0 ||
                grid.intensity[d] < 0)
                continue;
            for (uint32_t i : {a, b, d, a, d, c}) m.indices.push_back(i);
        }
    }
    return m;
}

std::string formatObj(const WarpMesh& mesh) {
    std::string out = "# parallax warp mesh: v = display coordinates, vt = pass-1 image (v up)\n";
    for (const DVec2& p : mesh.displayPos) out += fmt::format("v {:.9g} {:.9g} 0\n", p.x, p.y);
    for (const DVec2& t : mesh.uvs) out += fmt::format("vt {:.9g} {:.9g}\n", t.x, 1.0 - t.y);
    for (size_t i = 0; i < mesh.indices.size(); i += 3) {
        uint32_t a = mesh.indices[i] + 1, b = mesh.indices[i + 1] + 1, c = mesh.indices[i + 2] + 1;
        out += fmt::format("f {}/{} {}/{} {}/{}\n", a, a, b, b, c, c);
    }
    return out;
}

std::vector<uint8_t> encodeWarpPfm(const Display& display, const WarpMesh& mesh, int widthPx,
                                   int heightPx) {
    PLX_CHECK(widthPx >= 1 && heightPx >= 1);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<float> map(size_t(widthPx) * heightPx * 3, nan);
    DVec2 size(widthPx, heightPx);
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        const uint32_t* idx = &mesh.indices[3 * t];
        DVec2 p[3];
        for (int k = 0; k < 3; ++k) p[k] = normalisedFromDisplay(display, mesh.displayPos[idx[k]]) * size;
        DVec2 lo = glm::max(glm::min(p[0], glm::min(p[1], p[2])), DVec2(0.0));
        DVec2 hi = glm::min(glm::max(p[0], glm::max(p[1], p[2])), size);
        for (int y = int(lo.y); y < int(std::ceil(hi.y)); ++y) {
            for (int x = int(lo.x); x < int(std::ceil(hi.x)); ++x) {
                DVec3 w;
                if (!barycentric(DVec2(x + 0.5, y + 0.5), p[0], p[1], p[2], &w)) continue;
                if (w.x < 0 || w.y < 0 || w.z < 0) continue;
                DVec2 uv = w.x * mesh.uvs[idx[0]] + w.y * mesh.uvs[idx[1]] + w.z * mesh.uvs[idx[2]];
                float* px = &map[(size_t(heightPx - 1 - y) * widthPx + x) * 3];  // bottom-up rows
                px[0] = float(uv.x), px[1] = float(uv.y), px[2] = 0.0f;
            }
        }
    }
    std::string header = fmt::format("PF\n{} {}\n-1.0\n", widthPx, heightPx);
    std::vector<uint8_t> out(header.begin(), header.end());
    const auto* bytes = reinterpret_cast<const uint8_t*>(map.data());  // little-endian hosts
    out.insert(out.end(), bytes, bytes + map.size() * sizeof(float));
    return out;
}

}  // namespace plx::display
