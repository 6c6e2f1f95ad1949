// The database's JSON files (docs/stream-format.md): serialisers, and parsers that treat the
// bytes as untrusted (size limit, nesting depth checked before parsing, then every field).

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <plx/core/file.h>
#include <plx/stream/database.h>

namespace plx::stream {
namespace {

using nlohmann::json;

constexpr const char* kRootFormat = "parallax-stream";
constexpr const char* kCellFormat = "parallax-stream-cell";
constexpr const char* kPartFormat = "parallax-stream-part";
// Pixel counts stay below 2^53 so that a double holds them exactly (JSON readers in other
// languages parse every number as a double).
constexpr uint64_t kMaxPixels = uint64_t(1) << 53;

// The float's shortest decimal form as a double: the JSON shows "0.1", not the float's exact
// binary value, and parsing it back to float gives the same float.
double tidy(float value) {
    return std::strtod(fmt::format("{}", value).c_str(), nullptr);
}

json vec3Json(const Vec3& v) {
    return json::array({tidy(v.x), tidy(v.y), tidy(v.z)});
}

// Deepest nesting of arrays and objects, scanning outside strings; stops once past `limit`.
int nestingDepth(std::string_view text, int limit) {
    int depth = 0, deepest = 0;
    bool inString = false, escaped = false;
    for (char ch : text) {
        if (inString) {
            if (escaped)
                escaped = false;
            else if (ch == '\\')
                escaped = true;
            else if (ch == '"')
                inString = false;
        } else if (ch == '"') {
            inString = true;
        } else if (ch == '[' || ch == '{') {
            deepest = std::max(deepest, ++depth);
            if (deepest > limit) break;
        } else if (ch == ']' || ch == '}') {
            --depth;
        }
    }
    return deepest;
}

// Size and depth checks, then the parse; errors name the file kind and the position.
Result<json> parseJson(std::span<const uint8_t> bytes, size_t maxBytes, const char* what) {
    if (bytes.size() > maxBytes)
        return errorStatus(ErrorCode::kOutOfRange, fmt::format("{}: {} bytes, more than the {} "
                                                               "allowed",
                                                               what, bytes.size(), maxBytes));
    std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    if (nestingDepth(text, kMaxJsonDepth) > kMaxJsonDepth)
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("{}: JSON nested deeper than {}", what, kMaxJsonDepth));
    try {
        json doc = json::parse(text);
        if (!doc.is_object())
            return errorStatus(ErrorCode::kCorruptData, fmt::format("{}: not a JSON object", what));
        return doc;
    } catch (const json::parse_error& e) {
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("{}: JSON syntax error at {}", what,
                                       lineColumn(text, e.byte > 0 ? e.byte - 1 : 0)));
    } catch (const json::exception& e) {  // nlohmann's other errors
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("{}: JSON not readable (nlohmann error {})", what, e.id));
    }
}

// Reads the fields of one JSON object; the first failure is kept (later reads return defaults)
// and names the field by its path ("cell file: pvs[2].ach").
class Fields {
public:
    Fields(const json& obj, std::string path, Status* status)
        : mObj(obj), mPath(std::move(path)), mStatus(status) {}

    const json* get(const char* key, json::value_t type, const char* typeName) {
        if (!mStatus->isOk()) return nullptr;
        auto it = mObj.find(key);
        bool number = type == json::value_t::number_float;
        if (it == mObj.end() || !(number ? it->is_number() : it->type() == type)) {
            fail(key, it == mObj.end() ? "missing" : fmt::format("not {}", typeName));
            return nullptr;
        }
        return &*it;
    }
    uint64_t integer(const char* key, uint64_t lo, uint64_t hi) {
        const json* j = get(key, json::value_t::number_unsigned, "an unsigned integer");
        if (!j) return lo;
        uint64_t v = j->get<uint64_t>();
        if (v < lo || v > hi) fail(key, fmt::format("{} outside {}..{}", v, lo, hi));
        return v;
    }
    double number(const char* key, double lo, double hi) {
        const json* j = get(key, json::value_t::number_float, "a number");
        if (!j) return lo;
        double v = j->get<double>();
        if (!(v >= lo && v <= hi)) fail(key, fmt::format("{} outside [{}, {}]", v, lo, hi));
        return v;
    }
    std::string string(const char* key, size_t minBytes, size_t maxBytes) {
        const json* j = get(key, json::value_t::string, "a string");
        if (!j) return {};
        const std::string& s = j->get_ref<const std::string&>();
        if (s.size() < minBytes || s.size() > maxBytes)
            fail(key, fmt::format("{} bytes, outside {}..{}", s.size(), minBytes, maxBytes));
        return s;
    }
    std::string url(const char* key) {
        std::string u = string(key, 1, kMaxUrlBytes);
        if (mStatus->isOk()) {
            Status s = checkUrl(u);
            if (!s) fail(key, s.message());
        }
        return u;
    }
    Vec3 vec3(const char* key) {
        const json* j = get(key, json::value_t::array, "an array");
        if (!j) return Vec3(0.0f);
        if (j->size() != 3) return fail(key, "not 3 numbers"), Vec3(0.0f);
        Vec3 v(0.0f);
        for (int k = 0; k < 3; ++k) {
            const json& e = (*j)[size_t(k)];
            double d = e.is_number() ? e.get<double>() : NAN;
            if (!std::isfinite(d) || std::abs(d) > 1e30)
                return fail(key, "not 3 finite numbers"), Vec3(0.0f);
            v[k] = float(d);
        }
        return v;
    }
    bool has(const char* key) const { return mObj.contains(key); }
    const json* array(const char* key, size_t maxEntries) {
        const json* j = get(key, json::value_t::array, "an array");
        if (j && j->size() > maxEntries)
            fail(key, fmt::format("{} entries, more than {}", j->size(), maxEntries));
        return mStatus->isOk() ? j : nullptr;
    }
    void expectFormat(const char* format) {
        std::string f = string("format", 0, 64);
        if (mStatus->isOk() && f != format) fail("format", fmt::format("not \"{}\"", format));
        integer("version", kFormatVersion, kFormatVersion);
    }
    // A sub-object at `index` of an array (objects only).
    Fields element(const json& arr, size_t index, const char* key) {
        const json& e = arr[index];
        std::string path = fmt::format("{}.{}[{}]", mPath, key, index);
        if (mStatus->isOk() && !e.is_object())
            *mStatus = errorStatus(ErrorCode::kCorruptData, path + ": not an object");
        static const json kEmpty = json::object();
        return Fields(e.is_object() ? e : kEmpty, path, mStatus);
    }
    void fail(const std::string& key, const std::string& why) {
        if (mStatus->isOk())
            *mStatus =
                errorStatus(ErrorCode::kCorruptData, fmt::format("{}.{}: {}", mPath, key, why));
    }

private:
    const json& mObj;
    std::string mPath;
    Status* mStatus;
};

// An object {"min": [x,y,z], "max": [x,y,z]} with min <= max per axis.
void parseBox(Fields& f, const char* key, const std::string& path, Vec3* lo, Vec3* hi,
              Status* status) {
    const json* b = f.get(key, json::value_t::object, "an object");
    if (!b) return;
    Fields box(*b, path + "." + key, status);
    *lo = box.vec3("min");
    *hi = box.vec3("max");
    if (status->isOk() && glm::any(glm::greaterThan(*lo, *hi))) box.fail("min", "greater than max");
}

// A list of URLs, each checked, strictly ascending (sorted, no duplicates).
std::vector<std::string> urlList(Fields& f, const json* arr, const char* key) {
    std::vector<std::string> urls;
    if (!arr) return urls;
    for (size_t i = 0; i < arr->size(); ++i) {
        const json& e = (*arr)[i];
        Status s = e.is_string() ? checkUrl(e.get_ref<const std::string&>())
                                 : errorStatus(ErrorCode::kCorruptData, "not a string");
        if (!s) return f.fail(fmt::format("{}[{}]", key, i), s.message()), urls;
        urls.push_back(e.get<std::string>());
        if (i > 0 && urls[i - 1] >= urls[i])
            return f.fail(fmt::format("{}[{}]", key, i), "not in ascending order"), urls;
    }
    return urls;
}

void parsePvs(Fields& f, const json* arr, CellFile* cell, const std::string& self) {
    if (!arr) return;
    uint64_t pixelSum = 0;
    double achSum = 0.0;
    bool hasSelf = false;
    for (size_t i = 0; i < arr->size(); ++i) {
        Fields e = f.element(*arr, i, "pvs");
        PvsUrlEntry p;
        p.url = e.url("url");
        p.pixels = e.integer("pixels", 0, kMaxPixels);
        p.ach = e.number("ach", 0.0, 1.0);
        if (i > 0 && !(cell->pvs.back().url < p.url)) e.fail("url", "not in ascending order");
        hasSelf = hasSelf || p.url == self;
        pixelSum += p.pixels;
        achSum += p.ach;
        cell->pvs.push_back(std::move(p));
    }
    if (!hasSelf) f.fail("pvs", "does not hold the cell itself");
    if (pixelSum != cell->totalPixels)
        f.fail("pvs",
               fmt::format("pixels sum to {}, not total_pixels {}", pixelSum, cell->totalPixels));
    // Marvie section 5: the ACHs of a cell sum to 1 (each is rounded to a double).
    if (std::abs(achSum - 1.0) > 1e-6) f.fail("pvs", fmt::format("ACHs sum to {}", achSum));
}

// A list of [index, pixels] pairs (a part file's `seen` and `textures`, a cell file's
// `texture_coverage`): index < `count`, pixels > 0, ascending indices.
void pairList(Fields& f, const json* arr, const char* key, uint64_t count,
              std::vector<std::pair<uint32_t, uint64_t>>* out) {
    for (size_t k = 0; arr && k < arr->size(); ++k) {
        const json& e = (*arr)[k];
        bool pair =
            e.is_array() && e.size() == 2 && e[0].is_number_unsigned() && e[1].is_number_unsigned();
        uint64_t index = pair ? e[0].get<uint64_t>() : 0, px = pair ? e[1].get<uint64_t>() : 0;
        if (!pair || index >= count || px == 0 || px > kMaxPixels ||
            (k > 0 && out->back().first >= index)) {
            return f.fail(fmt::format("{}[{}]", key, k), "not an ascending [index, pixels] pair");
        }
        out->emplace_back(uint32_t(index), px);
    }
}

// Beyond the paper: each texture's pixels of the cell's sampling as [texture, pixels] pairs,
// summing to at most total_pixels (a pixel shows one texture at most).
void parseTextureCoverage(Fields& f, const json* arr, CellFile* cell) {
    pairList(f, arr, "texture_coverage", kMaxTextures, &cell->textureCoverage);
    uint64_t pixelSum = 0;  // each term <= 2^53: no overflow before the check fails
    for (const auto& [texture, pixels] : cell->textureCoverage) pixelSum += pixels;
    if (pixelSum > cell->totalPixels)
        f.fail("texture_coverage",
               fmt::format("pixels sum to more than total_pixels {}", cell->totalPixels));
}

// Parses a whole document: size, depth and syntax, the format string and version, then `body`
// reads the fields into a T; the first failure is the result.
template <class T, class Body>
Result<T> parseDocument(std::span<const uint8_t> bytes, size_t maxBytes, const char* what,
                        const char* path, const char* format, const Body& body) {
    auto doc = parseJson(bytes, maxBytes, what);
    if (!doc) return doc.status();
    Status status;
    Fields f(*doc, path, &status);
    f.expectFormat(format);
    T value;
    body(f, status, value);
    if (!status) return status;
    return value;
}

}  // namespace

std::string serializeRoot(const RootFile& root) {
    json vps = json::array();
    for (const RootViewpoint& v : root.viewpoints)
        vps.push_back({{"name", v.name},
                       {"eye", vec3Json(v.eyePos)},
                       {"target", vec3Json(v.targetPos)},
                       {"up", vec3Json(v.upDir)},
                       {"fov_y_degrees", tidy(v.fovYDegrees)},
                       {"cell", v.cellUrl}});
    json doc = {{"format", kRootFormat},
                {"version", kFormatVersion},
                {"scene", root.scene},
                {"bounds", {{"min", vec3Json(root.boundsMin)}, {"max", vec3Json(root.boundsMax)}}},
                {"cells", root.cells},
                {"textures", root.textures},
                {"viewpoints", vps}};
    return doc.dump();
}

std::string serializeCell(const CellFile& cell) {
    json textures = json::array(), pvs = json::array();
    for (const UrlBytes& t : cell.textures)
        textures.push_back({{"url", t.url}, {"bytes", t.bytes}});
    for (const PvsUrlEntry& p : cell.pvs)
        pvs.push_back({{"url", p.url}, {"pixels", p.pixels}, {"ach", p.ach}});
    json coverage = json::array();
    for (const auto& [texture, pixels] : cell.textureCoverage)
        coverage.push_back({texture, pixels});
    json doc = {{"format", kCellFormat},
                {"version", kFormatVersion},
                {"index", cell.index},
                {"hull", {{"min", vec3Json(cell.hullMin)}, {"max", vec3Json(cell.hullMax)}}},
                {"geometry",
                 {{"url", cell.geometry.url},
                  {"bytes", cell.geometry.bytes},
                  {"triangles", cell.triangles}}},
                {"textures", textures},
                {"adjacent", cell.adjacent},
                {"pvs", pvs},
                {"total_pixels", cell.totalPixels},
                {"texture_coverage", coverage},
                {"samples", cell.samples},
                {"face_size", cell.faceSize}};
    return doc.dump();
}

std::string serializePart(const PartFile& part) {
    json vis = json::array();
    for (const CellVisibility& v : part.visibility) {
        json seen = json::array(), textures = json::array();
        for (const auto& [cell, pixels] : v.seen) seen.push_back({cell, pixels});
        for (const auto& [texture, pixels] : v.textures) textures.push_back({texture, pixels});
        vis.push_back({{"cell", v.cell}, {"seen", seen}, {"textures", textures}});
    }
    json doc = {
        {"format", kPartFormat},   {"version", kFormatVersion},  {"scene_hash", part.sceneHash},
        {"cells", part.cells},     {"first", part.first},        {"last", part.last},
        {"samples", part.samples}, {"face_size", part.faceSize}, {"visibility", vis}};
    return doc.dump();
}

Result<RootFile> parseRoot(std::span<const uint8_t> bytes) {
    return parseDocument<RootFile>(
        bytes, kMaxRootBytes, "root file", "root", kRootFormat,
        [](Fields& f, Status& status, RootFile& root) {
            root.scene = f.string("scene", 0, 256);
            parseBox(f, "bounds", "root", &root.boundsMin, &root.boundsMax, &status);
            root.cells = uint32_t(f.integer("cells", 1, kMaxCells));
            root.textures = uint32_t(f.integer("textures", 0, kMaxTextures));
            const json* vps = f.array("viewpoints", kMaxViewpoints);
            if (vps && vps->empty()) f.fail("viewpoints", "empty");
            for (size_t i = 0; vps && status.isOk() && i < vps->size(); ++i) {
                Fields v = f.element(*vps, i, "viewpoints");
                RootViewpoint vp;
                vp.name = v.string("name", 1, 64);
                vp.eyePos = v.vec3("eye");
                vp.targetPos = v.vec3("target");
                vp.upDir = v.vec3("up");
                vp.fovYDegrees = float(v.number("fov_y_degrees", 1e-3, 179.999));
                vp.cellUrl = v.url("cell");
                if (status.isOk() && !cellIndexOfUrl(vp.cellUrl, root.cells))
                    v.fail("cell", "not the URL of one of the root's cells");
                Vec3 dir = vp.targetPos - vp.eyePos;
                if (status.isOk() && glm::length(dir) <= 0.0f) v.fail("target", "equals eye");
                if (status.isOk() && glm::length(glm::cross(glm::normalize(dir), vp.upDir)) < 1e-6f)
                    v.fail("up", "parallel to the view direction or zero");
                root.viewpoints.push_back(std::move(vp));
            }
        });
}

Result<CellFile> parseCell(std::span<const uint8_t> bytes) {
    return parseDocument<CellFile>(
        bytes, kMaxCellFileBytes, "cell file", "cell", kCellFormat,
        [](Fields& f, Status& status, CellFile& cell) {
            cell.index = uint32_t(f.integer("index", 0, kMaxCells - 1));
            parseBox(f, "hull", "cell", &cell.hullMin, &cell.hullMax, &status);
            if (const json* g = f.get("geometry", json::value_t::object, "an object")) {
                Fields geometry(*g, "cell.geometry", &status);
                cell.geometry.url = geometry.url("url");
                cell.geometry.bytes = geometry.integer("bytes", 0, kMaxGeometryBytes);
                cell.triangles = geometry.integer("triangles", 0, kMaxGeometryBytes / 12);
            }
            const json* textures = f.array("textures", kMaxListEntries);
            for (size_t i = 0; textures && status.isOk() && i < textures->size(); ++i) {
                Fields t = f.element(*textures, i, "textures");
                UrlBytes tex{t.url("url"), t.integer("bytes", 0, kMaxGeometryBytes)};
                if (i > 0 && !(cell.textures.back().url < tex.url)) t.fail("url", "not ascending");
                cell.textures.push_back(std::move(tex));
            }
            const std::string self = cellUrl(cell.index);
            cell.adjacent = urlList(f, f.array("adjacent", kMaxListEntries), "adjacent");
            if (std::find(cell.adjacent.begin(), cell.adjacent.end(), self) != cell.adjacent.end())
                f.fail("adjacent", "holds the cell itself");
            cell.totalPixels = f.integer("total_pixels", 0, kMaxPixels);
            cell.samples = int(f.integer("samples", 1, kMaxSamples));
            cell.faceSize = int(f.integer("face_size", kMinFaceSize, kMaxFaceSize));
            parsePvs(f, f.array("pvs", kMaxListEntries), &cell, self);
            if (f.has("texture_coverage"))
                parseTextureCoverage(f, f.array("texture_coverage", kMaxListEntries), &cell);
        });
}

Result<PartFile> parsePart(std::span<const uint8_t> bytes) {
    return parseDocument<PartFile>(
        bytes, kMaxPartBytes, "part file", "part", kPartFormat,
        [](Fields& f, Status& status, PartFile& part) {
            part.sceneHash = f.string("scene_hash", 16, 16);
            part.cells = uint32_t(f.integer("cells", 1, kMaxCells));
            part.first = uint32_t(f.integer("first", 0, part.cells - 1));
            part.last = uint32_t(f.integer("last", part.first, part.cells - 1));
            part.samples = int(f.integer("samples", 1, kMaxSamples));
            part.faceSize = int(f.integer("face_size", kMinFaceSize, kMaxFaceSize));
            const json* vis = f.array("visibility", kMaxCells);
            if (vis && status.isOk() && vis->size() != size_t(part.last - part.first + 1))
                f.fail("visibility", "does not hold one entry per cell of the range");
            for (size_t i = 0; vis && status.isOk() && i < vis->size(); ++i) {
                Fields v = f.element(*vis, i, "visibility");
                CellVisibility cv;
                cv.cell = uint32_t(v.integer("cell", part.first + i, part.first + i));
                pairList(v, v.array("seen", part.cells), "seen", part.cells, &cv.seen);
                if (v.has("textures"))
                    pairList(v, v.array("textures", kMaxListEntries), "textures", kMaxListEntries,
                             &cv.textures);
                part.visibility.push_back(std::move(cv));
            }
        });
}

std::string cellUrl(uint32_t cell) {
    return fmt::format("cells/c{:05}.json", cell);
}
std::string geometryUrl(uint32_t cell) {
    return fmt::format("cells/c{:05}.glb", cell);
}
std::string textureUrl(uint32_t texture) {
    return fmt::format("textures/t{:05}.ptm", texture);
}

Status checkUrl(std::string_view url) {
    auto bad = [&](const char* why) {
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("URL of {} bytes {}", url.size(), why));
    };
    if (url.empty() || url.size() > kMaxUrlBytes) return bad("outside 1..200 bytes");
    size_t start = 0;
    while (start <= url.size()) {
        size_t end = url.find('/', start);
        if (end == std::string_view::npos) end = url.size();
        std::string_view seg = url.substr(start, end - start);
        if (seg.empty()) return bad("has an empty segment (absolute, or '//')");
        if (seg == "." || seg == "..") return bad("has a '.' or '..' segment");
        for (char ch : seg)
            if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '.' || ch == '_' ||
                  ch == '-'))
                return bad("holds a character outside [A-Za-z0-9._-/] (a scheme, query or escape)");
        start = end + 1;
    }
    return Status::ok();
}

Result<uint32_t> cellIndexOfUrl(std::string_view url, uint32_t cellCount) {
    // cells/c + at least five digits + .json, as cellUrl writes it.
    constexpr std::string_view kPrefix = "cells/c", kSuffix = ".json";
    uint32_t index = 0;
    if (url.size() >= kPrefix.size() + 5 + kSuffix.size() && url.starts_with(kPrefix) &&
        url.ends_with(kSuffix)) {
        const char* b = url.data() + kPrefix.size();
        const char* e = url.data() + url.size() - kSuffix.size();
        auto [p, ec] = std::from_chars(b, e, index);
        if (ec == std::errc() && p == e && index < cellCount && cellUrl(index) == url) return index;
    }
    return errorStatus(
        ErrorCode::kCorruptData,
        fmt::format("URL of {} bytes names none of the {} cells", url.size(), cellCount));
}

}  // namespace plx::stream
