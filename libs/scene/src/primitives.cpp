#include <plx/scene/primitives.h>

namespace plx::scene {
namespace {

uint32_t addVertex(Mesh* mesh, const Vec3& p, const Vec3& n, const Vec2& uv) {
    mesh->positions.push_back(p);
    mesh->normals.push_back(n);
    mesh->uvs.push_back(uv);
    return uint32_t(mesh->positions.size() - 1);
}

void addTriangle(Mesh* mesh, uint32_t a, uint32_t b, uint32_t c) {
    mesh->indices.insert(mesh->indices.end(), {a, b, c});
}

Vec3 yawed(const Vec3& v, float c, float s) { return {c * v.x + s * v.z, v.y, -s * v.x + c * v.z}; }

}  // namespace

void appendQuad(Mesh* mesh, const Vec3& corner, const Vec3& edgeU, const Vec3& edgeV,
                const Vec2 uvs[4]) {
    Vec3 n = glm::normalize(glm::cross(edgeU, edgeV));
    uint32_t v0 = addVertex(mesh, corner, n, uvs[0]);
    uint32_t v1 = addVertex(mesh, corner + edgeU, n, uvs[1]);
    uint32_t v2 = addVertex(mesh, corner + edgeU + edgeV, n, uvs[2]);
    uint32_t v3 = addVertex(mesh, corner + edgeV, n, uvs[3]);
    addTriangle(mesh, v0, v1, v2);
    addTriangle(mesh, v0, v2, v3);
}

void appendBox(Mesh* mesh, const Vec3& center, const Vec3& halfExtents, float yawRadians,
               float uvMetres) {
    PLX_DCHECK(halfExtents.x > 0 && halfExtents.y > 0 && halfExtents.z > 0 && uvMetres > 0);
    float c = std::cos(yawRadians), s = std::sin(yawRadians);
    const Vec3 axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int a = 0; a < 3; ++a) {
        for (int sign = -1; sign <= 1; sign += 2) {
            // Tangents u, v with u x v = the outward normal: e(a+1) x e(a+2) = e(a), and the
            // pair swapped for the negative face.
            int ua = (a + 1) % 3, va = (a + 2) % 3;
            if (sign < 0) std::swap(ua, va);
            Vec3 n = axes[a] * float(sign);
            Vec3 u = axes[ua] * halfExtents[ua], v = axes[va] * halfExtents[va];
            Vec3 corner = n * halfExtents[a] - u - v;
            float su = 2.0f * halfExtents[ua] / uvMetres, sv = 2.0f * halfExtents[va] / uvMetres;
            // Image rows grow downwards, so v runs from 1 at the corner to 0 along edgeV.
            const Vec2 uvs[4] = {{0, sv}, {su, sv}, {su, 0}, {0, 0}};
            appendQuad(mesh, center + yawed(corner, c, s), yawed(2.0f * u, c, s),
                       yawed(2.0f * v, c, s), uvs);
        }
    }
}

void appendCylinder(Mesh* mesh, const Vec3& baseCenter, float radius, float height,
                    int segments) {
    PLX_DCHECK(radius > 0 && height > 0 && segments >= 3);
    Vec3 up(0, height, 0);
    auto ring = [&](int k) {
        float t = 2.0f * kPi * float(k % segments) / float(segments);
        return Vec3(std::cos(t), 0.0f, std::sin(t));
    };
    // Sides: the quad (bottom k, top k, top k+1, bottom k+1) faces outwards because the angle
    // grows from +x towards +z.
    for (int k = 0; k < segments; ++k) {
        Vec3 d0 = ring(k), d1 = ring(k + 1);
        float u0 = float(k) / float(segments), u1 = float(k + 1) / float(segments);
        uint32_t b0 = addVertex(mesh, baseCenter + radius * d0, d0, {u0, 1});
        uint32_t t0 = addVertex(mesh, baseCenter + radius * d0 + up, d0, {u0, 0});
        uint32_t t1 = addVertex(mesh, baseCenter + radius * d1 + up, d1, {u1, 0});
        uint32_t b1 = addVertex(mesh, baseCenter + radius * d1, d1, {u1, 1});
        addTriangle(mesh, b0, t0, t1);
        addTriangle(mesh, b0, t1, b1);
    }
    // Caps: fans around the centre, (c, k+1, k) facing +y on top, (c, k, k+1) facing -y below.
    for (int cap = 0; cap < 2; ++cap) {
        Vec3 n(0, cap ? 1.0f : -1.0f, 0);
        Vec3 centre = baseCenter + (cap ? up : Vec3(0.0f));
        uint32_t cIdx = addVertex(mesh, centre, n, {0.5f, 0.5f});
        uint32_t first = uint32_t(mesh->positions.size());
        for (int k = 0; k < segments; ++k) {
            Vec3 d = ring(k);
            addVertex(mesh, centre + radius * d, n, {0.5f + 0.5f * d.x, 0.5f - 0.5f * d.z});
        }
        for (int k = 0; k < segments; ++k) {
            uint32_t a = first + uint32_t(k), b = first + uint32_t((k + 1) % segments);
            if (cap) addTriangle(mesh, cIdx, b, a);
            else addTriangle(mesh, cIdx, a, b);
        }
    }
}

}  // namespace plx::scene
