// The isolated import's wire form (scene_wire.h): a plain writer over a sink and a bounds-checked
// reader over untrusted bytes.

#include "scene_wire.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <type_traits>

#include <fmt/format.h>

namespace plx::scene::wire {
namespace {

constexpr char kMagic[8] = {'P', 'L', 'X', 'S', 'C', 'N', 'W', '1'};

class Writer {
public:
    explicit Writer(const Sink& sink) : mSink(sink) {}
    bool ok() const { return mOk; }

    void bytes(const void* p, size_t n) {
        if (mOk && n > 0) mOk = mSink(p, n);
    }
    template <class T>
    void pod(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes(&v, sizeof v);
    }
    void str(const std::string& s) {
        pod(uint64_t(s.size()));
        bytes(s.data(), s.size());
    }
    template <class T>
    void array(const std::vector<T>& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        pod(uint64_t(v.size()));
        bytes(v.data(), v.size() * sizeof(T));
    }

private:
    const Sink& mSink;
    bool mOk = true;
};

// Reads fields from untrusted bytes: each read checks what is left, each count is bounded by
// the bytes left before anything is allocated, and the first failure names the field.
class Reader {
public:
    explicit Reader(std::span<const uint8_t> bytes) : mBytes(bytes) {}
    const Status& status() const { return mStatus; }
    bool atEnd() const { return mPos == mBytes.size(); }
    size_t left() const { return mBytes.size() - mPos; }

    bool bytes(void* out, size_t n, const char* what) {
        if (!mStatus) return false;
        if (n > mBytes.size() - mPos) return fail(fmt::format("{} past the end", what));
        if (n > 0) std::memcpy(out, mBytes.data() + mPos, n);
        mPos += n;
        return true;
    }
    template <class T>
    bool pod(T* v, const char* what) {
        return bytes(v, sizeof(T), what);
    }
    // A count of items each at least minBytes long that must fit in the bytes left.
    bool count(uint64_t* n, size_t minBytes, const char* what) {
        if (!pod(n, what)) return false;
        if (*n > (mBytes.size() - mPos) / (minBytes ? minBytes : 1))
            return fail(fmt::format("{} count {} larger than the message", what, *n));
        return true;
    }
    bool str(std::string* s, const char* what) {
        uint64_t n = 0;
        if (!count(&n, 1, what)) return false;
        s->resize(size_t(n));
        return bytes(s->data(), size_t(n), what);
    }
    template <class T>
    bool array(std::vector<T>* v, const char* what) {
        uint64_t n = 0;
        if (!count(&n, sizeof(T), what)) return false;
        v->resize(size_t(n));
        return bytes(v->data(), size_t(n) * sizeof(T), what);
    }
    bool fail(std::string message) {
        if (mStatus) mStatus = errorStatus(ErrorCode::kCorruptData, "import result: " + message);
        return false;
    }

private:
    std::span<const uint8_t> mBytes;
    size_t mPos = 0;
    Status mStatus;
};

void writeMesh(Writer& w, const Mesh& m) {
    w.str(m.name);
    w.pod(int32_t(m.materialIndex));
    w.array(m.positions);
    w.array(m.normals);
    w.array(m.uvs);
    w.array(m.indices);
}

void writeTexture(Writer& w, const Texture& t) {
    w.str(t.name);
    w.pod(uint32_t(t.mips.size()));
    for (const Image<Rgba8>& mip : t.mips) {
        w.pod(int32_t(mip.width()));
        w.pod(int32_t(mip.height()));
        w.bytes(mip.data(), size_t(mip.width()) * size_t(mip.height()) * sizeof(Rgba8));
    }
}

bool readMesh(Reader& r, Mesh* m) {
    int32_t material = 0;
    bool ok = r.str(&m->name, "mesh name") && r.pod(&material, "mesh material") &&
              r.array(&m->positions, "positions") && r.array(&m->normals, "normals") &&
              r.array(&m->uvs, "uvs") && r.array(&m->indices, "indices");
    m->materialIndex = material;
    return ok;
}

// A mip level of the expected size (the base level: 1 to 2^15 texels a side); its texels must fit
// in the bytes left before the image is allocated.
bool readMip(Reader& r, int expectW, int expectH, Image<Rgba8>* mip) {
    int32_t w = 0, h = 0;
    if (!r.pod(&w, "texture width") || !r.pod(&h, "texture height")) return false;
    bool base = expectW == 0;
    bool bad = base ? (w <= 0 || h <= 0 || w > (1 << 15) || h > (1 << 15))
                    : (w != expectW || h != expectH);
    if (bad) return r.fail(fmt::format("texture level of {}x{} texels out of sequence", w, h));
    size_t n = size_t(w) * size_t(h) * sizeof(Rgba8);
    if (n > r.left()) return r.fail("texels past the end");
    mip->resize(w, h);
    return r.bytes(mip->data(), n, "texels");
}

// A texture whose levels halve (rounding up) down to 1x1, as buildMipChain makes them.
bool readTexture(Reader& r, Texture* t) {
    uint32_t levels = 0;
    if (!r.str(&t->name, "texture name") || !r.pod(&levels, "texture levels")) return false;
    if (levels == 0 || levels > 16) return r.fail(fmt::format("texture with {} levels", levels));
    t->mips.resize(levels);
    for (uint32_t k = 0; k < levels; ++k) {
        int w = k == 0 ? 0 : std::max(1, (t->mips[k - 1].width() + 1) / 2);
        int h = k == 0 ? 0 : std::max(1, (t->mips[k - 1].height() + 1) / 2);
        if (!readMip(r, w, h, &t->mips[k])) return false;
    }
    if (t->mips.back().width() != 1 || t->mips.back().height() != 1)
        return r.fail("texture levels stop before 1x1");
    return true;
}

bool readMaterial(Reader& r, Material* m) {
    int32_t tex = -1;
    bool ok = r.str(&m->name, "material name") && r.pod(&m->baseColor, "base colour") &&
              r.pod(&tex, "material texture");
    m->baseColorTexture = tex;
    return ok;
}

bool readViewpoint(Reader& r, Viewpoint* v) {
    return r.str(&v->name, "viewpoint name") && r.pod(&v->eyePos, "eye position") &&
           r.pod(&v->targetPos, "target position") && r.pod(&v->upDir, "up direction") &&
           r.pod(&v->fovYDegrees, "field of view");
}

// A list: u64 count (each item at least minBytes) and the items read by readItem.
template <class T, class F>
bool readList(Reader& r, std::vector<T>* out, size_t minBytes, const char* what, F readItem) {
    uint64_t n = 0;
    if (!r.count(&n, minBytes, what)) return false;
    out->resize(size_t(n));
    for (T& item : *out)
        if (!readItem(r, &item)) return false;
    return true;
}

bool readScene(Reader& r, Scene* s) {
    uint64_t degenerate = 0, missing = 0;
    if (!r.pod(&degenerate, "degenerate count") || !r.pod(&missing, "missing textures"))
        return false;
    s->degenerateTrianglesDropped = size_t(degenerate);
    s->texturesMissing = size_t(missing);
    auto readWarning = [](Reader& rr, std::string* w) { return rr.str(w, "warning"); };
    return readList(r, &s->warnings, 8, "warnings", readWarning) &&
           readList(r, &s->meshes, 44, "meshes", readMesh) &&
           readList(r, &s->materials, 28, "materials", readMaterial) &&
           readList(r, &s->textures, 12, "textures", readTexture) &&
           readList(r, &s->viewpoints, 48, "viewpoints", readViewpoint);
}

}  // namespace

bool encodeScene(const Scene& s, const Sink& sink) {
    Writer w(sink);
    w.bytes(kMagic, sizeof kMagic);
    w.pod(WireOutcome::kScene);
    w.pod(uint64_t(s.degenerateTrianglesDropped));
    w.pod(uint64_t(s.texturesMissing));
    w.pod(uint64_t(s.warnings.size()));
    for (const std::string& warning : s.warnings) w.str(warning);
    w.pod(uint64_t(s.meshes.size()));
    for (const Mesh& m : s.meshes) writeMesh(w, m);
    w.pod(uint64_t(s.materials.size()));
    for (const Material& m : s.materials) {
        w.str(m.name);
        w.pod(m.baseColor);
        w.pod(int32_t(m.baseColorTexture));
    }
    w.pod(uint64_t(s.textures.size()));
    for (const Texture& t : s.textures) writeTexture(w, t);
    w.pod(uint64_t(s.viewpoints.size()));
    for (const Viewpoint& v : s.viewpoints) {
        w.str(v.name);
        w.pod(v.eyePos);
        w.pod(v.targetPos);
        w.pod(v.upDir);
        w.pod(v.fovYDegrees);
    }
    return w.ok();
}

bool encodeError(WireOutcome outcome, const Status& status, const Sink& sink) {
    Writer w(sink);
    w.bytes(kMagic, sizeof kMagic);
    w.pod(outcome);
    w.pod(uint32_t(status.code()));
    w.str(status.message());
    return w.ok();
}

Result<Decoded> decode(std::span<const uint8_t> bytes) {
    Reader r(bytes);
    char magic[8] = {};
    uint8_t outcome = 0;
    if (!r.bytes(magic, sizeof magic, "header") || std::memcmp(magic, kMagic, sizeof magic) != 0)
        return errorStatus(ErrorCode::kCorruptData, "import result: bad header");
    if (!r.pod(&outcome, "outcome")) return r.status();
    Decoded d;
    d.outcome = WireOutcome(outcome);
    if (d.outcome == WireOutcome::kError || d.outcome == WireOutcome::kOutOfMemory) {
        uint32_t code = 0;
        std::string message;
        if (!r.pod(&code, "error code") || !r.str(&message, "error message")) return r.status();
        bool known = code > uint32_t(ErrorCode::kOk) && code <= uint32_t(ErrorCode::kInternal);
        d.status = errorStatus(known ? ErrorCode(code) : ErrorCode::kInternal, message);
    } else if (d.outcome == WireOutcome::kScene) {
        if (!readScene(r, &d.scene)) return r.status();
    } else {
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("import result: unknown outcome {}", outcome));
    }
    if (!r.atEnd()) return errorStatus(ErrorCode::kCorruptData, "import result: trailing bytes");
    return d;
}

}  // namespace plx::scene::wire
