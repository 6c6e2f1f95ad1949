#include "size_check.h"

#include <charconv>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace plx::scene {
namespace {

// Bytes of one binary PLY scalar type; 0 for an unknown name.
unsigned plyScalarBytes(const std::string& type) {
    static const std::map<std::string, unsigned> kSizes = {
        {"char", 1},  {"uchar", 1},  {"int8", 1},   {"uint8", 1},  {"short", 2},
        {"ushort", 2}, {"int16", 2}, {"uint16", 2}, {"int", 4},    {"uint", 4},
        {"int32", 4}, {"uint32", 4}, {"float", 4},  {"float32", 4}, {"double", 8},
        {"float64", 8}};
    auto it = kSizes.find(type);
    return it == kSizes.end() ? 0 : it->second;
}

struct PlyElement {
    std::string name;
    uint64_t count = 0;
    uint64_t minBytes = 0;  // smallest encoding of one element
};

Status checkElement(const PlyElement& e, uintmax_t bodyBytes, size_t maxElements) {
    if (e.count > maxElements)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("PLY header declares {} '{}' elements, more than the "
                                       "limit of {}",
                                       e.count, printable(e.name), maxElements));
    uint64_t perElement = std::max<uint64_t>(e.minBytes, 1);
    if (e.count > bodyBytes / perElement)
        return errorStatus(
            ErrorCode::kCorruptData,
            fmt::format("PLY header declares {} '{}' elements (at least {} bytes) "
                        "but only {} bytes follow the header",
                        e.count, printable(e.name), e.count * perElement, bodyBytes));
    return Status::ok();
}

}  // namespace

Status checkPlyCounts(const std::string& path, uintmax_t fileSize, size_t maxElements) {
    // Headers are short; 64 KiB bounds the scan on a file that never says end_header.
    constexpr size_t kMaxHeader = 64 * 1024;
    std::ifstream in(path, std::ios::binary);
    if (!in) return errorStatus(ErrorCode::kIoError, "cannot open the file");
    std::string head(std::min<uintmax_t>(fileSize, kMaxHeader), '\0');
    in.read(head.data(), std::streamsize(head.size()));
    head.resize(size_t(in.gcount()));
    if (head.rfind("ply", 0) != 0) return Status::ok();  // not PLY after all: assimp decides

    bool ascii = true;
    std::vector<PlyElement> elements;
    size_t pos = 0, bodyStart = std::string::npos;
    while (pos < head.size()) {
        size_t eol = head.find('\n', pos);
        if (eol == std::string::npos) break;
        std::istringstream line(head.substr(pos, eol - pos));
        pos = eol + 1;
        std::string word;
        line >> word;
        if (word == "end_header") {
            bodyStart = pos;
            break;
        }
        if (word == "format") {
            std::string fmtName;
            line >> fmtName;
            ascii = fmtName == "ascii";
        } else if (word == "element") {
            PlyElement e;
            std::string count;
            line >> e.name >> count;
            auto [end, ec] = std::from_chars(count.data(), count.data() + count.size(), e.count);
            if (ec != std::errc() || end != count.data() + count.size())
                return errorStatus(ErrorCode::kCorruptData,
                                   fmt::format("PLY element '{}' has a bad count '{}'",
                                               printable(e.name), printable(count)));
            elements.push_back(e);
        } else if (word == "property" && !elements.empty()) {
            std::string type, countType;
            line >> type;
            unsigned bytes = 2;  // ASCII: a digit and a separator at least
            if (!ascii) {
                if (type == "list") line >> countType;
                bytes = plyScalarBytes(type == "list" ? countType : type);
            }
            elements.back().minBytes += bytes;
        }
    }
    // A header cut short is refused here: assimp 5.2's PLY reader can loop forever on one.
    if (bodyStart == std::string::npos)
        return errorStatus(ErrorCode::kCorruptData,
                           head.size() >= kMaxHeader ? "PLY header has no end_header line"
                                                     : "PLY header is truncated (no end_header)");
    uintmax_t bodyBytes = fileSize - bodyStart;
    for (const PlyElement& e : elements) PLX_RETURN_IF_ERROR(checkElement(e, bodyBytes,
                                                                          maxElements));
    return Status::ok();
}

Status checkObjCounts(const std::string& path, size_t maxElements) {
    std::FILE* file = std::fopen(path.c_str(), "rb");
    if (!file) return errorStatus(ErrorCode::kIoError, "cannot open the file");
    uint64_t vertices = 0, triangles = 0;
    std::vector<char> buf(1 << 20);
    // Line state carried across buffer boundaries: start of line, the line's keyword, and the
    // number of corners of the face being read.
    bool lineStart = true, inWord = false;
    int keyword = 0;  // 0 other, 'v' vertex, 'f' face
    uint64_t corners = 0;
    auto endLine = [&] {
        if (keyword == 'f' && corners >= 3) triangles += corners - 2;
        lineStart = true;
        keyword = 0;
        corners = 0;
        inWord = false;
    };
    size_t got = 0;
    while ((got = std::fread(buf.data(), 1, buf.size(), file)) > 0) {
        for (size_t i = 0; i < got; ++i) {
            char c = buf[i];
            if (c == '\n') {
                endLine();
                continue;
            }
            bool space = c == ' ' || c == '\t' || c == '\r';
            if (lineStart) {
                if (space) continue;
                lineStart = false;
                // Only "v " and "f " count; "vt", "vn", "fo" do not.
                bool single = i + 1 < got && (buf[i + 1] == ' ' || buf[i + 1] == '\t');
                if (c == 'v' && single) keyword = 'v', ++vertices;
                if (c == 'f' && single) keyword = 'f';
                inWord = true;  // the keyword itself
                continue;
            }
            if (keyword == 'f') {
                if (space) {
                    inWord = false;
                } else if (!inWord) {
                    inWord = true;
                    ++corners;
                }
            }
        }
        if (vertices > maxElements || triangles > maxElements) break;
    }
    endLine();
    std::fclose(file);
    if (vertices > maxElements || triangles > maxElements)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("OBJ file holds more than {} vertices or triangles",
                                       maxElements));
    return Status::ok();
}

}  // namespace plx::scene

namespace plx::scene {
namespace {

// Next line of an OFF file that holds data: comments (#) and blank lines skipped.
bool nextOffLine(std::istream& in, std::istringstream* line, uint64_t* lineNo) {
    std::string text;
    while (std::getline(in, text)) {
        ++*lineNo;
        size_t hash = text.find('#');
        if (hash != std::string::npos) text.resize(hash);
        if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
        line->clear();
        line->str(text);
        return true;
    }
    return false;
}

}  // namespace

Status checkOffFile(const std::string& path, uintmax_t fileSize, size_t maxElements) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return errorStatus(ErrorCode::kIoError, "cannot open the file");
    std::istringstream line;
    uint64_t lineNo = 0;
    if (!nextOffLine(in, &line, &lineNo)) return Status::ok();  // empty: assimp decides
    std::string keyword;
    line >> keyword;
    // "OFF", "COFF", "NOFF", "STOFF", ...: only files that say they are OFF are checked.
    if (keyword.size() < 3 || keyword.compare(keyword.size() - 3, 3, "OFF") != 0)
        return Status::ok();
    uint64_t counts[2] = {0, 0};
    for (uint64_t& c : counts)
        if (!(line >> c) && !(nextOffLine(in, &line, &lineNo) && line >> c))
            return errorStatus(ErrorCode::kCorruptData, "OFF header has no vertex and face counts");
    const uint64_t vertices = counts[0], faces = counts[1];
    if (vertices > maxElements || faces > maxElements)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("OFF header declares {} vertices and {} faces, more than "
                                       "the limit of {}",
                                       vertices, faces, maxElements));
    // A vertex takes at least "0 0 0\n" (6 bytes), a face "1 0\n" (4 bytes).
    const uint64_t needed = 6 * vertices + 4 * faces;
    if (needed > fileSize)
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("OFF header declares {} vertices and {} faces (at least {} "
                                       "bytes) but the file holds {} bytes",
                                       vertices, faces, needed, fileSize));
    for (uint64_t v = 0; v < vertices; ++v)
        if (!nextOffLine(in, &line, &lineNo))
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("OFF file ends at vertex {} of {}", v, vertices));
    // assimp 5.2 clamps an out-of-range index to the last vertex and draws the face: refuse it.
    for (uint64_t f = 0; f < faces; ++f) {
        uint64_t corners = 0;
        if (!nextOffLine(in, &line, &lineNo) || !(line >> corners))
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("OFF file ends at face {} of {}", f, faces));
        for (uint64_t k = 0; k < corners; ++k) {
            int64_t index = -1;
            if (!(line >> index))
                return errorStatus(ErrorCode::kCorruptData,
                                   fmt::format("OFF face {} (line {}) has fewer than its {} "
                                               "corners",
                                               f, lineNo, corners));
            if (index < 0 || uint64_t(index) >= vertices)
                return errorStatus(ErrorCode::kCorruptData,
                                   fmt::format("OFF face {} (line {}) refers to vertex {} of {}", f,
                                               lineNo, index, vertices));
        }
    }
    return Status::ok();
}

}  // namespace plx::scene

namespace plx::scene {
namespace {

using Json = nlohmann::json;

// The JSON text of a .gltf file, or the JSON chunk of a .glb file.
Result<std::string> gltfJsonText(const std::string& path, uintmax_t fileSize) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return errorStatus(ErrorCode::kIoError, "cannot open the file");
    char head[20] = {};
    in.read(head, sizeof(head));
    size_t got = size_t(in.gcount());
    if (got >= 4 && std::memcmp(head, "glTF", 4) == 0) {
        if (got < 20) return errorStatus(ErrorCode::kCorruptData, "GLB header is truncated");
        uint32_t length = 0;
        std::memcpy(&length, head + 12, 4);
        if (std::memcmp(head + 16, "JSON", 4) != 0 || length > fileSize - 20)
            return errorStatus(ErrorCode::kCorruptData, "GLB has no complete JSON chunk");
        std::string text(length, '\0');
        in.read(text.data(), std::streamsize(length));
        return text;
    }
    std::string text(size_t(fileSize), '\0');
    in.seekg(0);
    in.read(text.data(), std::streamsize(text.size()));
    text.resize(size_t(in.gcount()));
    return text;
}

uint64_t jsonCount(const Json& array, const Json& indexValue) {
    if (!indexValue.is_number_unsigned() || !array.is_array()) return 0;
    uint64_t i = indexValue.get<uint64_t>();
    if (i >= array.size() || !array[i].is_object()) return 0;
    auto it = array[i].find("count");
    return it != array[i].end() && it->is_number_unsigned() ? it->get<uint64_t>() : 0;
}

// Triangles one glTF mesh declares: the index (or position) count of each triangle primitive.
uint64_t gltfMeshTriangles(const Json& doc, const Json& mesh) {
    const Json& accessors = doc.contains("accessors") ? doc["accessors"] : Json();
    uint64_t total = 0;
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
        return 0;
    for (const Json& p : mesh["primitives"]) {
        if (!p.is_object()) continue;
        int mode = p.contains("mode") && p["mode"].is_number_integer() ? p["mode"].get<int>() : 4;
        if (mode < 4 || mode > 6) continue;  // points and lines
        uint64_t n = p.contains("indices") ? jsonCount(accessors, p["indices"])
                     : p.contains("attributes") && p["attributes"].is_object() &&
                             p["attributes"].contains("POSITION")
                         ? jsonCount(accessors, p["attributes"]["POSITION"])
                         : 0;
        total += mode == 4 ? n / 3 : (n >= 2 ? n - 2 : 0);
    }
    return total;
}

// Node copies and triangles of each node's expanded subtree, memoized: linear in the node graph
// however often it is instanced.
struct GltfExpansion {
    const Json& doc;
    const Json& nodes;
    std::vector<int> state;  // 0 unvisited, 1 on the stack, 2 done
    std::vector<uint64_t> copies, triangles;

    // Saturating sum: the counts of a hostile graph grow exponentially with its depth.
    static uint64_t add(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }

    Status visit(uint64_t n, int depth) {
        constexpr int kMaxDepth = 1024;  // as collectInstances in import.cpp
        if (n >= nodes.size())
            return errorStatus(ErrorCode::kCorruptData, fmt::format("glTF node {} missing", n));
        if (state[n] == 2) return Status::ok();
        if (state[n] == 1)
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("glTF node {} is its own descendant (a cycle)", n));
        if (depth > kMaxDepth)
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("glTF node hierarchy deeper than {}", kMaxDepth));
        state[n] = 1;
        const Json& node = nodes[n];
        uint64_t c = 1, t = 0;
        if (node.is_object() && node.contains("mesh") && doc.contains("meshes") &&
            node["mesh"].is_number_unsigned() &&
            node["mesh"].get<uint64_t>() < doc["meshes"].size())
            t = gltfMeshTriangles(doc, doc["meshes"][node["mesh"].get<uint64_t>()]);
        if (node.is_object() && node.contains("children") && node["children"].is_array()) {
            for (const Json& child : node["children"]) {
                if (!child.is_number_unsigned())
                    return errorStatus(ErrorCode::kCorruptData,
                                       fmt::format("glTF node {} has a bad child index", n));
                uint64_t k = child.get<uint64_t>();
                PLX_RETURN_IF_ERROR(visit(k, depth + 1));
                c = add(c, copies[k]);
                t = add(t, triangles[k]);
            }
        }
        copies[n] = c;
        triangles[n] = t;
        state[n] = 2;
        return Status::ok();
    }
};

// The nodes assimp starts from: those of every scene (an overestimate when a file has several),
// or, without scenes, the nodes that are nobody's child.
std::vector<uint64_t> gltfRoots(const Json& doc) {
    const Json& nodes = doc["nodes"];
    std::vector<uint64_t> roots;
    if (doc.contains("scenes") && doc["scenes"].is_array()) {
        for (const Json& scene : doc["scenes"])
            if (scene.is_object() && scene.contains("nodes") && scene["nodes"].is_array())
                for (const Json& n : scene["nodes"])
                    if (n.is_number_unsigned()) roots.push_back(n.get<uint64_t>());
        return roots;
    }
    std::vector<bool> isChild(nodes.size(), false);
    for (const Json& node : nodes)
        if (node.is_object() && node.contains("children") && node["children"].is_array())
            for (const Json& c : node["children"])
                if (c.is_number_unsigned() && c.get<uint64_t>() < nodes.size())
                    isChild[c.get<uint64_t>()] = true;
    for (uint64_t n = 0; n < nodes.size(); ++n)
        if (!isChild[n]) roots.push_back(n);
    return roots;
}

}  // namespace

Status checkGltfExpansion(const std::string& path, uintmax_t fileSize, size_t maxNodes,
                          size_t maxTriangles) {
    auto text = gltfJsonText(path, fileSize);
    if (!text) return text.status();
    Json doc = Json::parse(*text, nullptr, false);
    // Invalid JSON, or no nodes: assimp reports what is wrong.
    if (doc.is_discarded() || !doc.is_object() || !doc.contains("nodes") ||
        !doc["nodes"].is_array())
        return Status::ok();
    const Json& nodes = doc["nodes"];
    GltfExpansion e{doc, nodes, std::vector<int>(nodes.size(), 0),
                    std::vector<uint64_t>(nodes.size(), 0), std::vector<uint64_t>(nodes.size(), 0)};
    uint64_t copies = 0, triangles = 0;
    for (uint64_t n : gltfRoots(doc)) {
        PLX_RETURN_IF_ERROR(e.visit(n, 0));
        copies = GltfExpansion::add(copies, e.copies[n]);
        triangles = GltfExpansion::add(triangles, e.triangles[n]);
    }
    if (copies > maxNodes)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("glTF node graph expands to more than the limit of {} "
                                       "node copies (nodes listed as children more than once "
                                       "are copied each time)",
                                       maxNodes));
    if (triangles > maxTriangles)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("glTF meshes instanced by the node graph make more than "
                                       "the limit of {} triangles",
                                       maxTriangles));
    return Status::ok();
}

}  // namespace plx::scene

namespace plx::scene {
namespace {

// Tokens of a text .x file: separators are white space, ';' and ','; comments (# or //) run to
// the end of the line; '{' and '}' are tokens of their own.
class XTokens {
public:
    explicit XTokens(std::string text) : mText(std::move(text)) {}

    bool next(std::string* token) {
        token->clear();
        while (mPos < mText.size()) {
            char c = mText[mPos];
            if (c == '#' || (c == '/' && mPos + 1 < mText.size() && mText[mPos + 1] == '/')) {
                size_t eol = mText.find('\n', mPos);
                mPos = eol == std::string::npos ? mText.size() : eol;
            } else if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == ';' || c == ',') {
                ++mPos;
            } else {
                break;
            }
        }
        if (mPos >= mText.size()) return false;
        if (mText[mPos] == '{' || mText[mPos] == '}') {
            *token = mText[mPos++];
            return true;
        }
        while (mPos < mText.size() && std::strchr(" \t\r\n;,{}", mText[mPos]) == nullptr)
            token->push_back(mText[mPos++]);
        return true;
    }

    bool number(int64_t* value) {
        std::string t;
        if (!next(&t)) return false;
        auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), *value);
        return ec == std::errc() && end == t.data() + t.size();
    }

    // Bytes not yet read.
    size_t left() const { return mText.size() - mPos; }

    bool skipNumbers(uint64_t count) {
        std::string t;
        for (uint64_t i = 0; i < count; ++i)
            if (!next(&t) || t == "{" || t == "}") return false;
        return true;
    }

private:
    std::string mText;
    size_t mPos = 0;
};

// A count the mesh declares against the bytes left after it: each item needs at least
// minBytes (a number and a separator for each of its values). assimp reserves the count first.
Status checkXCount(const XTokens& tokens, int64_t count, size_t minBytes, const char* what,
                   int meshNumber) {
    if (uint64_t(count) <= tokens.left() / minBytes) return Status::ok();
    return errorStatus(ErrorCode::kCorruptData,
                       fmt::format(".x mesh {} declares {} {}, more than the {} bytes after it "
                                   "can hold",
                                   meshNumber, count, what, tokens.left()));
}

// One "Mesh [name] {" block from just after its brace: the declared counts against the file's
// size, the face indices against the vertex count. A block that does not parse (a template) is
// left to assimp.
Status checkXMesh(XTokens* tokens, int meshNumber) {
    int64_t vertices = 0, faces = 0;
    if (!tokens->number(&vertices) || vertices < 0) return Status::ok();
    PLX_RETURN_IF_ERROR(checkXCount(*tokens, vertices, 5, "vertices", meshNumber));
    if (!tokens->skipNumbers(3 * uint64_t(vertices))) return Status::ok();
    if (!tokens->number(&faces) || faces < 0) return Status::ok();
    PLX_RETURN_IF_ERROR(checkXCount(*tokens, faces, 2, "faces", meshNumber));
    for (int64_t f = 0; f < faces; ++f) {
        int64_t corners = 0;
        if (!tokens->number(&corners) || corners < 0) return Status::ok();
        for (int64_t k = 0; k < corners; ++k) {
            int64_t index = 0;
            if (!tokens->number(&index)) return Status::ok();
            if (index < 0 || index >= vertices)
                return errorStatus(ErrorCode::kCorruptData,
                                   fmt::format(".x mesh {} face {} refers to vertex {} of {}",
                                               meshNumber, f, index, vertices));
        }
    }
    return Status::ok();
}

}  // namespace

Status checkXFaces(const std::string& path, uintmax_t fileSize) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return errorStatus(ErrorCode::kIoError, "cannot open the file");
    std::string text(size_t(fileSize), '\0');
    in.read(text.data(), std::streamsize(text.size()));
    text.resize(size_t(in.gcount()));
    // Text files only ("xof 0303txt"); binary and compressed ones are left to assimp.
    if (text.size() < 16 || text.compare(0, 4, "xof ") != 0 || text.compare(8, 3, "txt") != 0)
        return Status::ok();
    XTokens tokens(std::move(text));
    std::string t, previous, beforePrevious;
    int meshes = 0;
    while (tokens.next(&t)) {
        // "Mesh {" or "Mesh name {", but not "template Mesh {".
        bool opensMesh = t == "{" && (previous == "Mesh" || beforePrevious == "Mesh") &&
                         beforePrevious != "template" && previous != "template";
        if (opensMesh) PLX_RETURN_IF_ERROR(checkXMesh(&tokens, meshes++));
        beforePrevious = previous;
        previous = t;
    }
    return Status::ok();
}

}  // namespace plx::scene
