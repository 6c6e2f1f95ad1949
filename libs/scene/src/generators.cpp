// Procedural scenes: the P-buffer paper's open-plan office (Heo, Jung, Wohn, section V and
// Table 1), a textured museum and the curved displays' showcase exhibit. Everything is
// deterministic: variety comes from a fixed integer hash, never from a platform random generator.

#include <plx/scene/generators.h>

#include <algorithm>
#include <charconv>
#include <set>

#include <fmt/format.h>

#include <plx/scene/primitives.h>

namespace plx::scene {
namespace {

// A fixed 32-bit integer hash (lowbias32, Chris Wellons): same bits on every platform.
uint32_t hash32(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

uint32_t hash32(uint32_t a, uint32_t b) { return hash32(a ^ hash32(b + 0x9e3779b9U)); }

// Uniform in [0, 1) from a hash.
float unitFloat(uint32_t h) { return float(h >> 8) * (1.0f / 16777216.0f); }

// ---------------------------------------------------------------------------------------------
// office:N

// Materials of the office, one merged mesh each.
enum OfficeMaterial {
    kFloorMat,
    kDeskWoodMat,
    kChairFabricMat,
    kPartitionMat,
    kShelfMat,
    kPostMat,
    kMetalMat,
    kBookMat,
    kOfficeMaterialCount
};

constexpr float kRoomSize = 8.0f;  // metres; each room is kRoomSize x kRoomSize on the floor

std::vector<Material> officeMaterials() {
    return {
        {"floor", {0.42f, 0.40f, 0.36f, 1.0f}, -1},
        {"desk_wood", {0.55f, 0.36f, 0.18f, 1.0f}, -1},
        {"chair_fabric", {0.10f, 0.16f, 0.40f, 1.0f}, -1},
        {"partition", {0.55f, 0.58f, 0.52f, 1.0f}, -1},
        {"shelf", {0.45f, 0.30f, 0.16f, 1.0f}, -1},
        {"post", {0.75f, 0.75f, 0.72f, 1.0f}, -1},
        {"metal", {0.20f, 0.20f, 0.22f, 1.0f}, -1},
        {"books", {0.50f, 0.12f, 0.10f, 1.0f}, -1},
    };
}

// Floor of one room: kFloorTiles x kFloorTiles quads facing up (a tiled carpet, so that the floor
// is made of many polygons like the rest of the model).
constexpr int kFloorTiles = 8;

void addFloor(std::vector<Mesh>& m) {
    float tile = kRoomSize / kFloorTiles;
    const Vec2 uvs[4] = {{0, 1}, {0, 0}, {1, 0}, {1, 1}};
    for (int j = 0; j < kFloorTiles; ++j)
        for (int i = 0; i < kFloorTiles; ++i)
            // +z edge first: (z-edge) x (x-edge) = +y.
            appendQuad(&m[kFloorMat], Vec3(i * tile, 0, j * tile), Vec3(0, 0, tile),
                       Vec3(tile, 0, 0), uvs);
}

// A desk facing +z (the worker sits on the -z side when facing = +1): top, two side panels, a
// modesty panel, a drawer pedestal with three drawer fronts and handles.
void addDesk(std::vector<Mesh>& m, const Vec3& c, float facing) {
    const float w = 0.8f, d = 0.4f, h = 0.75f;  // half width, half depth; height
    Mesh& wood = m[kDeskWoodMat];
    appendBox(&wood, c + Vec3(0, h - 0.02f, 0), Vec3(w, 0.02f, d));
    appendBox(&wood, c + Vec3(-w + 0.02f, (h - 0.04f) / 2, 0), Vec3(0.02f, (h - 0.04f) / 2, d));
    appendBox(&wood, c + Vec3(w - 0.02f, (h - 0.04f) / 2, 0), Vec3(0.02f, (h - 0.04f) / 2, d));
    appendBox(&wood, c + Vec3(0, 0.45f, facing * (d - 0.03f)), Vec3(w - 0.04f, 0.25f, 0.01f));
    Vec3 ped = c + Vec3(w - 0.25f, 0.35f, 0);
    appendBox(&wood, ped, Vec3(0.20f, 0.34f, d - 0.05f));
    for (int k = 0; k < 3; ++k) {
        float y = 0.14f + 0.22f * float(k);
        Vec3 front = ped + Vec3(0, y - 0.35f, -facing * (d - 0.04f));
        appendBox(&wood, front, Vec3(0.18f, 0.09f, 0.01f));
        appendBox(&m[kMetalMat], front + Vec3(0, 0.04f, -facing * 0.02f),
                  Vec3(0.06f, 0.01f, 0.01f));
    }
}

// A swivel chair turned by yaw about its column: seat, back with support, arm rests, gas column
// (cylinder) and a five-legged star base.
void addChair(std::vector<Mesh>& m, const Vec3& c, float yaw) {
    float cs = std::cos(yaw), sn = std::sin(yaw);
    auto at = [&](const Vec3& local) {
        return c + Vec3(cs * local.x + sn * local.z, local.y, -sn * local.x + cs * local.z);
    };
    Mesh& fabric = m[kChairFabricMat];
    Mesh& metal = m[kMetalMat];
    appendBox(&fabric, at({0, 0.47f, 0}), {0.24f, 0.04f, 0.24f}, yaw);
    appendBox(&fabric, at({0, 0.82f, 0.22f}), {0.22f, 0.22f, 0.03f}, yaw);
    appendBox(&metal, at({0, 0.57f, 0.25f}), {0.03f, 0.08f, 0.015f}, yaw);
    for (float side : {-1.0f, 1.0f}) {
        appendBox(&fabric, at({side * 0.25f, 0.68f, 0.0f}), {0.03f, 0.02f, 0.16f}, yaw);
        appendBox(&metal, at({side * 0.25f, 0.58f, 0.05f}), {0.012f, 0.08f, 0.012f}, yaw);
    }
    appendCylinder(&metal, c + Vec3(0, 0.08f, 0), 0.03f, 0.35f, 8);
    for (int k = 0; k < 5; ++k) {
        float legYaw = yaw + 2.0f * kPi * float(k) / 5.0f;
        Vec3 dir(std::sin(legYaw), 0, std::cos(legYaw));
        appendBox(&metal, c + dir * 0.16f + Vec3(0, 0.06f, 0), {0.025f, 0.02f, 0.16f}, legYaw);
    }
}

// Monitor (screen, neck, foot) and keyboard on a desk top at height y.
void addComputer(std::vector<Mesh>& m, const Vec3& deskCentre, float facing) {
    Mesh& metal = m[kMetalMat];
    Vec3 top = deskCentre + Vec3(0, 0.75f, 0);
    appendBox(&metal, top + Vec3(0, 0.38f, facing * 0.18f), {0.30f, 0.19f, 0.02f});
    appendBox(&metal, top + Vec3(0, 0.10f, facing * 0.22f), {0.03f, 0.10f, 0.02f});
    appendBox(&metal, top + Vec3(0, 0.01f, facing * 0.22f), {0.12f, 0.01f, 0.08f});
    appendBox(&metal, top + Vec3(0, 0.015f, -facing * 0.12f), {0.22f, 0.015f, 0.08f});
}

// A low partition panel (1.2 m) with a top rail, running along x (alongX) or z.
void addPartition(std::vector<Mesh>& m, const Vec3& from, float length, bool alongX) {
    Vec3 half = alongX ? Vec3(length / 2, 0.6f, 0.03f) : Vec3(0.03f, 0.6f, length / 2);
    Vec3 c = from + (alongX ? Vec3(length / 2, 0.6f, 0) : Vec3(0, 0.6f, length / 2));
    appendBox(&m[kPartitionMat], c, half);
    Vec3 rail = alongX ? Vec3(length / 2, 0.02f, 0.04f) : Vec3(0.04f, 0.02f, length / 2);
    appendBox(&m[kMetalMat], c + Vec3(0, 0.62f, 0), rail);
}

// A bookshelf open towards -z: two sides, back, top, bottom, three shelves, and rows of books
// whose heights and thicknesses vary by a fixed hash.
void addShelf(std::vector<Mesh>& m, const Vec3& c) {
    const float w = 0.9f, d = 0.175f, h = 1.8f;
    Mesh& shelf = m[kShelfMat];
    appendBox(&shelf, c + Vec3(-w + 0.02f, h / 2, 0), {0.02f, h / 2, d});
    appendBox(&shelf, c + Vec3(w - 0.02f, h / 2, 0), {0.02f, h / 2, d});
    appendBox(&shelf, c + Vec3(0, h / 2, d - 0.01f), {w - 0.04f, h / 2, 0.01f});
    for (int k = 0; k < 5; ++k)  // bottom, three shelves, top
        appendBox(&shelf, c + Vec3(0, 0.02f + float(k) * 0.44f, -0.01f),
                  {w - 0.04f, 0.02f, d - 0.01f});
    for (int level = 0; level < 3; ++level) {
        float x = -w + 0.08f;
        for (int b = 0; b < 8; ++b) {
            uint32_t hsh = hash32(uint32_t(level * 16 + b), 0xb00c5U);
            float halfT = 0.03f + 0.03f * unitFloat(hsh);
            float halfH = 0.11f + 0.06f * unitFloat(hash32(hsh));
            float y = 0.04f + float(level) * 0.44f + halfH;
            appendBox(&m[kBookMat], c + Vec3(x + halfT, y, -0.02f), {halfT, halfH, 0.13f});
            x += 2.0f * halfT + 0.01f;
        }
    }
}

// One room of the office in [0, kRoomSize]^2 on the floor: two rows of three workstations
// back to back along a spine of low partitions with dividers, two bookshelves and four posts.
std::vector<Mesh> buildOfficeRoom() {
    std::vector<Mesh> m(kOfficeMaterialCount);
    addFloor(m);
    const float deskX[3] = {1.75f, 4.0f, 6.25f};
    for (int i = 0; i < 3; ++i) {
        for (int row = 0; row < 2; ++row) {
            // Row 0 sits on the -z side of the spine at z = 3.5 facing +z, row 1 mirrors it.
            float facing = row == 0 ? 1.0f : -1.0f;
            Vec3 desk(deskX[i], 0, 3.5f - facing * 0.45f);
            addDesk(m, desk, facing);
            addComputer(m, desk, facing);
            float yaw = (row == 0 ? kPi : 0.0f) +
                        0.6f * (unitFloat(hash32(uint32_t(i * 2 + row), 0xc4a1U)) - 0.5f);
            addChair(m, desk - Vec3(0, 0, facing * 0.85f), yaw);
        }
    }
    for (int k = 0; k < 3; ++k) addPartition(m, Vec3(1.0f + 2.0f * k, 0, 3.5f), 2.0f, true);
    for (float x : {2.875f, 5.125f}) {
        addPartition(m, Vec3(x, 0, 2.3f), 1.17f, false);
        addPartition(m, Vec3(x, 0, 3.53f), 1.17f, false);
    }
    addShelf(m, Vec3(2.1f, 0, 7.45f));
    addShelf(m, Vec3(5.9f, 0, 7.45f));
    const Vec2 postXz[4] = {{0.5f, 3.5f}, {7.5f, 3.5f}, {4.0f, 6.6f}, {4.0f, 0.6f}};
    for (const Vec2& p : postXz) {
        appendBox(&m[kPostMat], Vec3(p.x, 0.05f, p.y), {0.25f, 0.05f, 0.25f});
        appendCylinder(&m[kPostMat], Vec3(p.x, 0.1f, p.y), 0.18f, 2.9f, 24);
    }
    return m;
}

// Appends `src` translated by offset to `dst`.
void appendTranslated(Mesh* dst, const Mesh& src, const Vec3& offset) {
    uint32_t base = uint32_t(dst->positions.size());
    for (const Vec3& p : src.positions) dst->positions.push_back(p + offset);
    dst->normals.insert(dst->normals.end(), src.normals.begin(), src.normals.end());
    dst->uvs.insert(dst->uvs.end(), src.uvs.begin(), src.uvs.end());
    for (uint32_t i : src.indices) dst->indices.push_back(base + i);
}

int gridColumns(int rooms) {
    int cols = 1;
    while (cols * cols < rooms) ++cols;
    return cols;
}

// A viewpoint at `eye` looking diagonally across the grid (+x +z), `pitchDegrees` down.
Viewpoint diagonalViewpoint(const char* name, Vec3 eye, float pitchDegrees) {
    Viewpoint v;
    v.name = name;
    v.eyePos = eye;
    Vec3 dir(std::cos(radians(pitchDegrees)) * glm::normalize(Vec3(1, 0, 1)));
    dir.y = -std::sin(radians(pitchDegrees));
    v.targetPos = eye + 10.0f * dir;
    v.fovYDegrees = 60.0f;
    return v;
}

std::vector<Viewpoint> officeViewpoints(const Aabb& bounds) {
    // "default": standing in the corner room at eye height (1.6 m), looking diagonally across
    // the floor, 32 degrees down, so the top of the 60-degree view lies 2 degrees below the
    // horizon. Only what stands near the eye (furniture of the first rooms, posts) reaches into
    // the view, so the visible polygons level off as N grows, as in the paper's Table 1: at
    // 640x480, 1,027 at 3 rooms, 1,094 at 4 and 1,133 from 8 rooms on.
    Viewpoint inside = diagonalViewpoint("default", Vec3(0.4f, 1.6f, 0.4f), 32.0f);
    // "vista": the same place looking 12 degrees down, over the whole grid to the horizon; the
    // visible polygons keep growing up to about 100k triangles (2,864 at 280 rooms).
    Viewpoint vista = diagonalViewpoint("vista", Vec3(0.4f, 1.6f, 0.4f), 12.0f);
    Viewpoint overview;
    overview.name = "overview";
    Vec3 c = bounds.center();
    float span = std::max(bounds.extent().x, bounds.extent().z);
    overview.eyePos = Vec3(c.x, span * 0.9f + 5.0f, c.z + 0.35f * span);
    overview.targetPos = Vec3(c.x, 0.0f, c.z);
    overview.fovYDegrees = 60.0f;
    return {inside, vista, overview};
}

// ---------------------------------------------------------------------------------------------
// museum:N

constexpr float kMuseumRoom = 10.0f;    // room side, metres
constexpr float kMuseumHeight = 4.0f;   // wall height
constexpr float kWallThick = 0.2f;
constexpr float kDoorWidth = 1.8f;
constexpr float kDoorHeight = 2.6f;
// Paintings get their own texture up to this many; later ones reuse them cyclically, which
// bounds the texture memory of museum:1024 (about 80 MiB with mips).
constexpr int kMaxUniquePaintings = 128;

enum MuseumMaterial { kMuseumFloor, kMuseumWall, kMuseumCeiling, kMuseumFrame, kMuseumFixed };

Rgba8 rgb8(const Vec3& c) {
    Vec3 v = glm::clamp(c, Vec3(0.0f), Vec3(1.0f)) * 255.0f + 0.5f;  // round to nearest
    return {uint8_t(v.r), uint8_t(v.g), uint8_t(v.b), 255};
}

Vec3 hashColour(uint32_t h) {
    return {unitFloat(hash32(h, 1)), unitFloat(hash32(h, 2)), unitFloat(hash32(h, 3))};
}

// Smooth value noise on an integer lattice of period `cells` (tileable), in [0, 1).
float valueNoise(float x, float y, int cells, uint32_t seed) {
    int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    float fx = x - float(x0), fy = y - float(y0);
    auto lattice = [&](int i, int j) {
        int wi = ((i % cells) + cells) % cells, wj = ((j % cells) + cells) % cells;
        return unitFloat(hash32(uint32_t(wi * 4099 + wj), seed));
    };
    float sx = fx * fx * (3 - 2 * fx), sy = fy * fy * (3 - 2 * fy);
    float a = lattice(x0, y0) + sx * (lattice(x0 + 1, y0) - lattice(x0, y0));
    float b = lattice(x0, y0 + 1) + sx * (lattice(x0 + 1, y0 + 1) - lattice(x0, y0 + 1));
    return a + sy * (b - a);
}

float fractalNoise(float u, float v, int baseCells, uint32_t seed) {
    float sum = 0.0f, amp = 0.5f;
    int cells = baseCells;
    for (int o = 0; o < 5; ++o, cells *= 2, amp *= 0.5f)
        sum += amp * valueNoise(u * float(cells), v * float(cells), cells, seed + uint32_t(o));
    return sum;
}

// A painting's texels: one of six pattern families chosen by the hash, from flat colour fields
// (compress well) to fractal noise with grain (compress poorly).
Image<Rgba8> paintingImage(int width, int height, uint32_t seed) {
    Image<Rgba8> img(width, height);
    int pattern = int(hash32(seed, 7) % 6);
    Vec3 c0 = hashColour(seed), c1 = hashColour(seed + 101), c2 = hashColour(seed + 202);
    float freq = 3.0f + 9.0f * unitFloat(hash32(seed, 11));
    float angle = kPi * unitFloat(hash32(seed, 13));
    Vec2 centres[12];
    for (int k = 0; k < 12; ++k)
        centres[k] = {unitFloat(hash32(seed, 20 + k)), unitFloat(hash32(seed, 40 + k))};
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            float u = (float(x) + 0.5f) / float(width), v = (float(y) + 0.5f) / float(height);
            Vec3 c;
            switch (pattern) {
            case 0: {  // stripes at an angle
                float t = u * std::cos(angle) + v * std::sin(angle);
                c = std::fmod(t * freq, 1.0f) < 0.5f ? c0 : c1;
                break;
            }
            case 1: {  // blocks of flat colour
                int bx = int(u * freq * 0.5f), by = int(v * freq * 0.5f);
                uint32_t h = hash32(uint32_t(bx * 31 + by), seed);
                c = (h % 3 == 0) ? c0 : (h % 3 == 1 ? c1 : c2);
                break;
            }
            case 2: {  // concentric rings
                float r = glm::length(Vec2(u, v) - centres[0]);
                c = glm::mix(c0, c1, 0.5f + 0.5f * std::sin(r * freq * 6.0f));
                break;
            }
            case 3: {  // fractal value noise
                float n = fractalNoise(u, v, 4, seed);
                c = glm::mix(c0, c1, n) + 0.3f * (fractalNoise(u, v, 16, seed + 9) - 0.5f);
                break;
            }
            case 4: {  // vertical gradient with discs
                c = glm::mix(c0, c1, v);
                for (int k = 0; k < 5; ++k)
                    if (glm::length(Vec2(u, v) - centres[k]) < 0.05f + 0.1f * centres[k + 5].x)
                        c = glm::mix(c2, hashColour(seed + uint32_t(k)), 0.3f);
                break;
            }
            default: {  // cells around the nearest of twelve centres
                int best = 0;
                float bestD = 9.0f;
                for (int k = 0; k < 12; ++k) {
                    float d = glm::length(Vec2(u, v) - centres[k]);
                    if (d < bestD) bestD = d, best = k;
                }
                c = hashColour(seed * 13 + uint32_t(best)) * (1.0f - 0.6f * bestD);
                break;
            }
            }
            // Canvas grain on half of the paintings.
            if (hash32(seed, 17) & 1)
                c += 0.06f * (unitFloat(hash32(uint32_t(y * width + x), seed)) - 0.5f);
            img.at(x, y) = rgb8(c);
        }
    }
    return img;
}

// Floor: 4 x 4 stone tiles with grout per texture (the texture covers 2 m x 2 m).
Image<Rgba8> floorImage() {
    const int n = 256, tile = n / 4;
    Image<Rgba8> img(n, n);
    for (int y = 0; y < n; ++y) {
        for (int x = 0; x < n; ++x) {
            int tx = x / tile, ty = y / tile;
            bool grout = x % tile < 3 || y % tile < 3;
            float shade = 0.55f + 0.15f * unitFloat(hash32(uint32_t(ty * 4 + tx), 0xf100U)) +
                          0.1f * (fractalNoise(float(x) / n, float(y) / n, 8, 0xf1U) - 0.5f);
            Vec3 c = grout ? Vec3(0.25f) : Vec3(shade, shade * 0.93f, shade * 0.85f);
            img.at(x, y) = rgb8(c);
        }
    }
    return img;
}

// Walls: light plaster, tileable noise.
Image<Rgba8> wallImage() {
    const int n = 256;
    Image<Rgba8> img(n, n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            float s = 0.82f + 0.12f * (fractalNoise(float(x) / n, float(y) / n, 4, 0xa11U) - 0.5f);
            img.at(x, y) = rgb8(Vec3(s, s * 0.97f, s * 0.9f));
        }
    return img;
}

Texture makeTexture(std::string name, Image<Rgba8> base) {
    Texture t;
    t.name = std::move(name);
    t.mips.push_back(std::move(base));
    buildMipChain(&t);
    return t;
}

struct MuseumLayout {
    int rooms = 0;
    int cols = 0;
    bool exists(int c, int r) const {
        return c >= 0 && r >= 0 && c < cols && r * cols + c < rooms;
    }
};

// A wall on a grid line from a to b (along x or z), solid or with a centred doorway.
void addWall(Mesh* wall, const Vec3& a, const Vec3& b, bool door) {
    bool alongX = std::abs(b.x - a.x) > std::abs(b.z - a.z);
    Vec3 dir = glm::normalize(b - a);
    float len = glm::length(b - a);
    auto segment = [&](float t0, float t1, float y0, float y1) {
        Vec3 mid = a + dir * (0.5f * (t0 + t1)) + Vec3(0, 0.5f * (y0 + y1), 0);
        float halfLen = 0.5f * (t1 - t0), halfT = 0.5f * kWallThick;
        Vec3 half = alongX ? Vec3(halfLen, 0.5f * (y1 - y0), halfT)
                           : Vec3(halfT, 0.5f * (y1 - y0), halfLen);
        appendBox(wall, mid, half, 0.0f, 2.0f);
    };
    if (!door) {
        segment(0, len, 0, kMuseumHeight);
        return;
    }
    float d0 = 0.5f * (len - kDoorWidth), d1 = 0.5f * (len + kDoorWidth);
    segment(0, d0, 0, kMuseumHeight);
    segment(d1, len, 0, kMuseumHeight);
    segment(d0, d1, kDoorHeight, kMuseumHeight);
}

struct PaintingSlot {
    Vec3 centre;  // on the wall's inner face
    Vec3 inward;  // unit normal into the room
};

// A frame (box) and a canvas (textured quad facing into the room).
void addPainting(Mesh* frame, Mesh* canvas, const PaintingSlot& slot, float width, float height) {
    Vec3 up(0, 1, 0);
    Vec3 right = glm::cross(-slot.inward, up);  // the viewer's right when facing the wall
    bool alongX = std::abs(right.x) > 0.5f;
    float border = 0.06f, depth = 0.025f;
    Vec3 half = alongX ? Vec3(0.5f * width + border, 0.5f * height + border, depth)
                       : Vec3(depth, 0.5f * height + border, 0.5f * width + border);
    appendBox(frame, slot.centre + slot.inward * depth, half);
    Vec3 corner = slot.centre + slot.inward * (2.0f * depth + 0.002f) - right * (0.5f * width) -
                  up * (0.5f * height);
    // Bottom-left, bottom-right, top-right, top-left: the image's top row at the top.
    const Vec2 uvs[4] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
    appendQuad(canvas, corner, right * width, up * height, uvs);
}

// The painting slots of room (c, r): one per wall side, centred on solid walls and beside the
// doorway on walls that have one.
std::vector<PaintingSlot> paintingSlots(const MuseumLayout& layout, int c, int r) {
    float x0 = float(c) * kMuseumRoom, z0 = float(r) * kMuseumRoom, h = 0.5f * kMuseumRoom;
    float inner = 0.5f * kWallThick, y = 1.7f;
    struct Side {
        Vec3 centre, inward, along;
        bool door;
    };
    const Side sides[4] = {
        {{x0 + inner, y, z0 + h}, {1, 0, 0}, {0, 0, 1}, layout.exists(c - 1, r)},
        {{x0 + kMuseumRoom - inner, y, z0 + h}, {-1, 0, 0}, {0, 0, 1}, layout.exists(c + 1, r)},
        {{x0 + h, y, z0 + inner}, {0, 0, 1}, {1, 0, 0}, layout.exists(c, r - 1)},
        {{x0 + h, y, z0 + kMuseumRoom - inner}, {0, 0, -1}, {1, 0, 0}, layout.exists(c, r + 1)},
    };
    std::vector<PaintingSlot> slots;
    for (int s = 0; s < 4; ++s) {
        Vec3 p = sides[s].centre;
        if (sides[s].door) {
            float side = (hash32(uint32_t(r * layout.cols + c), uint32_t(s)) & 1) ? 1.0f : -1.0f;
            p += sides[s].along * (side * 2.8f);
        }
        slots.push_back({p, sides[s].inward});
    }
    return slots;
}

void addMuseumRoomShell(const MuseumLayout& layout, int c, int r, std::vector<Mesh>& m) {
    float x0 = float(c) * kMuseumRoom, z0 = float(r) * kMuseumRoom, x1 = x0 + kMuseumRoom,
          z1 = z0 + kMuseumRoom, t = 0.5f * kWallThick;
    // Floor (facing up) and ceiling (facing down); UVs in metres / 2 so the tiles repeat.
    float s = kMuseumRoom / 2.0f;
    const Vec2 floorUv[4] = {{0, s}, {0, 0}, {s, 0}, {s, s}};
    appendQuad(&m[kMuseumFloor], Vec3(x0, 0, z0), Vec3(0, 0, kMuseumRoom), Vec3(kMuseumRoom, 0, 0),
               floorUv);
    appendQuad(&m[kMuseumCeiling], Vec3(x0, kMuseumHeight, z0), Vec3(kMuseumRoom, 0, 0),
               Vec3(0, 0, kMuseumRoom), floorUv);
    // Walls span between corner pillars (addPillars) so that no two boxes overlap; this room
    // builds its
    // west and south walls (doorways where a neighbour exists) and its east and north walls
    // only on the museum's outside.
    Mesh* wall = &m[kMuseumWall];
    addWall(wall, {x0, 0, z0 + t}, {x0, 0, z1 - t}, layout.exists(c - 1, r));
    addWall(wall, {x0 + t, 0, z0}, {x1 - t, 0, z0}, layout.exists(c, r - 1));
    if (!layout.exists(c + 1, r)) addWall(wall, {x1, 0, z0 + t}, {x1, 0, z1 - t}, false);
    if (!layout.exists(c, r + 1)) addWall(wall, {x0 + t, 0, z1}, {x1 - t, 0, z1}, false);
}

// One pillar at every room corner (each is where walls meet), built once.
void addPillars(const MuseumLayout& layout, Mesh* wall) {
    std::set<std::pair<int, int>> corners;
    for (int i = 0; i < layout.rooms; ++i) {
        int c = i % layout.cols, r = i / layout.cols;
        for (int k = 0; k < 4; ++k) corners.insert({c + (k & 1), r + (k >> 1)});
    }
    Vec3 half(0.5f * kWallThick, 0.5f * kMuseumHeight, 0.5f * kWallThick);
    for (const auto& [i, j] : corners)
        appendBox(wall, Vec3(float(i) * kMuseumRoom, half.y, float(j) * kMuseumRoom), half, 0.0f,
                  2.0f);
}

// ---------------------------------------------------------------------------------------------
// showcase

// An axis-aligned box (centre, half sizes) without normals (finalize computes them per face).
void addShowcaseBox(Mesh* m, Vec3 c, Vec3 h) {
    static const int kFaces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1},
                                     {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    for (const auto& f : kFaces) {
        uint32_t base = uint32_t(m->positions.size());
        for (int k = 0; k < 4; ++k) {
            int i = f[k];
            m->positions.push_back(c + Vec3((i & 1) ? h.x : -h.x, (i & 2) ? h.y : -h.y,
                                            (i & 4) ? h.z : -h.z));
        }
        for (uint32_t idx : {0u, 2u, 1u, 0u, 3u, 2u}) m->indices.push_back(base + idx);
    }
}

// A UV sphere of rings x segments quads without normals (finalize smooths them).
void addShowcaseSphere(Mesh* m, Vec3 c, float r, int rings, int segments) {
    uint32_t base = uint32_t(m->positions.size());
    for (int i = 0; i <= rings; ++i) {
        float th = kPi * float(i) / float(rings);
        for (int j = 0; j <= segments; ++j) {
            float ph = 2.0f * kPi * float(j) / float(segments);
            m->positions.push_back(c + r * Vec3(std::sin(th) * std::cos(ph), std::cos(th),
                                                std::sin(th) * std::sin(ph)));
        }
    }
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            uint32_t a = base + uint32_t(i * (segments + 1) + j), b = a + uint32_t(segments + 1);
            for (uint32_t idx : {a, a + 1, b, a + 1, b + 1, b}) m->indices.push_back(idx);
        }
}

}  // namespace

Result<Scene> generateOffice(int rooms) {
    if (rooms < 1 || rooms > kMaxOfficeRooms)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("office room count {} outside 1..{}", rooms,
                                       kMaxOfficeRooms));
    std::vector<Mesh> room = buildOfficeRoom();
    Scene scene;
    scene.materials = officeMaterials();
    scene.meshes.resize(kOfficeMaterialCount);
    for (int k = 0; k < kOfficeMaterialCount; ++k) {
        Mesh& mesh = scene.meshes[size_t(k)];
        mesh.name = scene.materials[size_t(k)].name;
        mesh.materialIndex = k;
        const Mesh& src = room[size_t(k)];
        mesh.positions.reserve(src.positions.size() * size_t(rooms));
        mesh.normals.reserve(src.normals.size() * size_t(rooms));
        mesh.uvs.reserve(src.uvs.size() * size_t(rooms));
        mesh.indices.reserve(src.indices.size() * size_t(rooms));
    }
    // Rooms copied onto a near-square grid of ceil(sqrt(N)) columns, as the paper copies its
    // office room one to fifteen times (Table 1); the corner room (0, 0) holds the viewpoint.
    int cols = gridColumns(rooms);
    for (int r = 0; r < rooms; ++r) {
        Vec3 offset(float(r % cols) * kRoomSize, 0.0f, float(r / cols) * kRoomSize);
        for (int k = 0; k < kOfficeMaterialCount; ++k)
            appendTranslated(&scene.meshes[size_t(k)], room[size_t(k)], offset);
    }
    PLX_RETURN_IF_ERROR(scene.finalize());
    // Room boxes up to the tallest furniture (the office has no ceiling).
    for (int r = 0; r < rooms; ++r) {
        Vec3 lo(float(r % cols) * kRoomSize, scene.bounds().lo.y, float(r / cols) * kRoomSize);
        scene.rooms.push_back({lo, Vec3(lo.x + kRoomSize, scene.bounds().hi.y, lo.z + kRoomSize)});
    }
    scene.viewpoints = officeViewpoints(scene.bounds());
    return scene;
}

Result<Scene> generateMuseum(int rooms) {
    if (rooms < 1 || rooms > kMaxMuseumRooms)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("museum room count {} outside 1..{}", rooms,
                                       kMaxMuseumRooms));
    MuseumLayout layout{rooms, gridColumns(rooms)};
    Scene scene;
    scene.materials = {{"floor", {1, 1, 1, 1}, 0},
                       {"wall", {1, 1, 1, 1}, 1},
                       {"ceiling", {0.9f, 0.9f, 0.88f, 1}, -1},
                       {"frame", {0.30f, 0.20f, 0.08f, 1}, -1}};
    std::vector<Mesh> m(kMuseumFixed);
    for (int k = 0; k < kMuseumFixed; ++k) {
        m[size_t(k)].name = scene.materials[size_t(k)].name;
        m[size_t(k)].materialIndex = k;
    }
    // Painting slots first, so that their textures can be made in parallel.
    std::vector<PaintingSlot> slots;
    for (int i = 0; i < rooms; ++i) {
        int c = i % layout.cols, r = i / layout.cols;
        addMuseumRoomShell(layout, c, r, m);
        for (const PaintingSlot& s : paintingSlots(layout, c, r)) slots.push_back(s);
    }
    addPillars(layout, &m[kMuseumWall]);
    int unique = std::min<int>(int(slots.size()), kMaxUniquePaintings);
    // Sizes 256x256, 512x512 and 512x256 (landscape), chosen by the hash.
    std::vector<IVec2> sizes(static_cast<size_t>(unique));
    for (int p = 0; p < unique; ++p) {
        uint32_t h = hash32(uint32_t(p), 0x512U) % 4;
        sizes[size_t(p)] = h == 0 ? IVec2(512, 512) : (h == 1 ? IVec2(512, 256) : IVec2(256, 256));
    }
    std::vector<Texture> paintings(static_cast<size_t>(unique));
    ThreadPool pool;
    pool.parallelFor(size_t(unique), 1, [&](size_t begin, size_t end) {
        for (size_t p = begin; p < end; ++p)
            paintings[p] = makeTexture(fmt::format("painting{}", p),
                                       paintingImage(sizes[p].x, sizes[p].y,
                                                     hash32(uint32_t(p), 0x9a1e77U)));
    });
    scene.textures.push_back(makeTexture("floor_tiles", floorImage()));
    scene.textures.push_back(makeTexture("wall_plaster", wallImage()));
    for (int p = 0; p < unique; ++p) {
        scene.materials.push_back({fmt::format("painting{}", p), {1, 1, 1, 1},
                                   int(scene.textures.size())});
        scene.textures.push_back(std::move(paintings[size_t(p)]));
    }
    for (size_t p = 0; p < slots.size(); ++p) {
        int tex = int(p % size_t(unique));
        Mesh canvas;
        canvas.name = fmt::format("painting{}", p);
        canvas.materialIndex = kMuseumFixed + tex;
        float height = 1.3f, width = height * float(sizes[size_t(tex)].x) /
                                     float(sizes[size_t(tex)].y);
        addPainting(&m[kMuseumFrame], &canvas, slots[p], width, height);
        m.push_back(std::move(canvas));
    }
    scene.meshes = std::move(m);
    PLX_RETURN_IF_ERROR(scene.finalize());
    for (int i = 0; i < rooms; ++i) {
        Vec3 lo(float(i % layout.cols) * kMuseumRoom, 0.0f, float(i / layout.cols) * kMuseumRoom);
        scene.rooms.push_back({lo, lo + Vec3(kMuseumRoom, kMuseumHeight, kMuseumRoom)});
    }
    // Inside room 0, looking along +x through the doorway into room 1 (when there is one).
    Viewpoint inside;
    inside.name = "default";
    inside.eyePos = Vec3(1.5f, 1.6f, 0.5f * kMuseumRoom);
    inside.targetPos = Vec3(kMuseumRoom + 4.0f, 1.5f, 0.5f * kMuseumRoom);
    inside.fovYDegrees = 60.0f;
    Viewpoint overview = framingViewpoint(scene.bounds());
    overview.name = "overview";
    scene.viewpoints = {inside, overview};
    return scene;
}

Result<Scene> generateShowcase() {
    Scene s;
    Material stone{"stone", {0.75f, 0.7f, 0.6f, 1.0f}, -1};
    Material bronze{"bronze", {0.7f, 0.45f, 0.2f, 1.0f}, -1};
    s.materials = {stone, bronze};
    Mesh pedestal{"pedestal", {}, {}, {}, {}, 0};
    addShowcaseBox(&pedestal, {0.0f, -0.35f, 0.0f}, {0.12f, 0.05f, 0.12f});
    Mesh figure{"figure", {}, {}, {}, {}, 1};
    addShowcaseSphere(&figure, {0.0f, -0.12f, 0.0f}, 0.12f, 16, 24);
    addShowcaseSphere(&figure, {0.0f, 0.1f, 0.0f}, 0.08f, 12, 18);
    addShowcaseSphere(&figure, {0.04f, 0.24f, 0.0f}, 0.05f, 10, 14);
    s.meshes = {pedestal, figure};
    PLX_RETURN_IF_ERROR(s.finalize());
    Viewpoint framing = framingViewpoint(s.bounds());
    framing.name = "default";
    s.viewpoints = {framing};
    return s;
}

bool isCountFreeGenerator(const std::string& name) { return name == "showcase"; }

namespace {

// A parsed generator spec: its name, and its room count (0 for a count-free generator).
struct GeneratorSpec {
    std::string name;
    int rooms = 0;
};

Result<GeneratorSpec> parseGeneratorSpec(const std::string& spec) {
    size_t colon = spec.find(':');
    std::string name = spec.substr(0, colon);
    if (isCountFreeGenerator(name)) {
        if (colon != std::string::npos)
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("scene generator '{}' takes no count", name));
        return GeneratorSpec{name, 0};
    }
    if (name != "office" && name != "museum")
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("unknown scene generator '{}' (known: office:N, museum:N, "
                                       "showcase)",
                                       name));
    int maxRooms = name == "office" ? kMaxOfficeRooms : kMaxMuseumRooms;
    std::string arg = colon == std::string::npos ? "" : spec.substr(colon + 1);
    long long n = 0;
    auto [end, ec] = std::from_chars(arg.data(), arg.data() + arg.size(), n);
    if (arg.empty() || ec != std::errc() || end != arg.data() + arg.size() || n < 1 ||
        n > maxRooms)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("bad room count in '{}': expected an integer in 1..{}",
                                       spec, maxRooms));
    return GeneratorSpec{name, int(n)};
}

// The parsed spec's scene with `rooms` rooms (ignored by a count-free generator).
Result<Scene> generate(const GeneratorSpec& g, int rooms) {
    if (g.rooms == 0) return generateShowcase();
    return g.name == "office" ? generateOffice(rooms) : generateMuseum(rooms);
}

}  // namespace

Result<Scene> generateFromSpec(const std::string& spec) {
    auto g = parseGeneratorSpec(spec);
    if (!g) return g.status();
    return generate(*g, g->rooms);
}

Result<size_t> generatedTriangleBound(const std::string& spec) {
    auto g = parseGeneratorSpec(spec);
    if (!g) return g.status();
    auto one = generate(*g, 1);
    if (!one) return one.status();
    return one->triangleCount() * size_t(std::max(g->rooms, 1));
}

}  // namespace plx::scene
