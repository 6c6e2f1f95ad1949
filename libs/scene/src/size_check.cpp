#include "size_check.h"

#include <charconv>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include <fmt/format.h>

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
                                       e.count, e.name, maxElements));
    uint64_t perElement = std::max<uint64_t>(e.minBytes, 1);
    if (e.count > bodyBytes / perElement)
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("PLY header declares {} '{}' elements (at least {} bytes) "
                                       "but only {} bytes follow the header",
                                       e.count, e.name, e.count * perElement, bodyBytes));
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
                                   fmt::format("PLY element '{}' has a bad count '{}'", e.name,
                                               count));
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
