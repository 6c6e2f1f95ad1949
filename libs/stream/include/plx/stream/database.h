#pragma once
// The scene database (Marvie & Bouatouch section 6; docs/stream-format.md): root file, one file
// per cell, one glTF binary per cell, one PTM file per texture. The structs mirror the JSON
// files field by field; the parsers read them as untrusted bytes, the writers produce them.

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <plx/core/core.h>
#include <plx/scene/scene.h>
#include <plx/stream/cells.h>
#include <plx/stream/visibility.h>

namespace plx::stream {

constexpr int kFormatVersion = 1;
constexpr size_t kMaxRootBytes = size_t(16) << 20;
constexpr size_t kMaxCellFileBytes = size_t(8) << 20;
constexpr size_t kMaxPartBytes = size_t(256) << 20;
constexpr uint64_t kMaxGeometryBytes = uint64_t(1) << 30;
constexpr int kMaxViewpoints = 1024;
constexpr int kMaxTextures = 65536;
constexpr int kMaxListEntries = 65536;
constexpr size_t kMaxUrlBytes = 200;
constexpr int kMaxJsonDepth = 8;

// A viewpoint of the root file and the cell holding its eye.
struct RootViewpoint {
    std::string name;
    Vec3 eyePos{0.0f}, targetPos{0.0f, 0.0f, -1.0f}, upDir{0.0f, 1.0f, 0.0f};
    float fovYDegrees = 60.0f;
    std::string cellUrl;
    friend bool operator==(const RootViewpoint&, const RootViewpoint&) = default;
};

struct RootFile {
    std::string scene;
    Vec3 boundsMin{0.0f}, boundsMax{0.0f};
    uint32_t cells = 0;
    uint32_t textures = 0;
    std::vector<RootViewpoint> viewpoints;
    friend bool operator==(const RootFile&, const RootFile&) = default;
};

struct UrlBytes {
    std::string url;
    uint64_t bytes = 0;
    friend bool operator==(const UrlBytes&, const UrlBytes&) = default;
};

struct PvsUrlEntry {
    std::string url;
    uint64_t pixels = 0;
    double ach = 0.0;
    friend bool operator==(const PvsUrlEntry&, const PvsUrlEntry&) = default;
};

struct CellFile {
    uint32_t index = 0;
    Vec3 hullMin{0.0f}, hullMax{0.0f};
    UrlBytes geometry;
    uint64_t triangles = 0;
    std::vector<UrlBytes> textures;
    std::vector<std::string> adjacent;
    std::vector<PvsUrlEntry> pvs;
    uint64_t totalPixels = 0;
    // Beyond the paper: the pixels of the sampling per texture (texture coverage hints), as
    // (texture k, pixels) ascending in k (texture k's file is textureUrl(k)); empty in databases
    // written before them.
    std::vector<std::pair<uint32_t, uint64_t>> textureCoverage;
    int samples = 0;
    int faceSize = 0;
    friend bool operator==(const CellFile&, const CellFile&) = default;
};

// A range build's result (docs/stream-format.md, "Range builds").
struct PartFile {
    std::string sceneHash;
    uint32_t cells = 0, first = 0, last = 0;
    int samples = 0, faceSize = 0;
    std::vector<CellVisibility> visibility;  // cells first..last in order
};

// The file names of the database, relative to its root folder.
std::string cellUrl(uint32_t cell);
std::string geometryUrl(uint32_t cell);
std::string textureUrl(uint32_t texture);

// Checks a URL against the format's rule (relative, [A-Za-z0-9._-] segments, no "." or "..",
// no scheme); the message says what is wrong without quoting more than the URL's length.
Status checkUrl(std::string_view url);
// The cell index named by a URL of the form cells/cNNNNN.json below `cellCount`.
Result<uint32_t> cellIndexOfUrl(std::string_view url, uint32_t cellCount);

// Parsers of untrusted bytes: size limit, JSON depth, every field's type, range and invariant.
// Errors are one line naming the field.
Result<RootFile> parseRoot(std::span<const uint8_t> bytes);
Result<CellFile> parseCell(std::span<const uint8_t> bytes);
Result<PartFile> parsePart(std::span<const uint8_t> bytes);

// Serialisers: compact JSON with sorted keys, the same bytes for the same struct.
std::string serializeRoot(const RootFile& root);
std::string serializeCell(const CellFile& cell);
std::string serializePart(const PartFile& part);

// FNV-1a 64 of the scene's positions, indices and the cell boxes, as 16 hex digits: ties a part
// file to the scene and cell rule it was computed for.
std::string sceneHash(const scene::Scene& scene, const Cells& cells);

struct BuildStats {
    size_t cells = 0;
    size_t textures = 0;
    uint64_t bytes = 0;          // all files written
    uint64_t textureBytes = 0;   // the PTM files
    uint64_t geometryBytes = 0;  // the glTF binaries
};

// Writes the whole database into `dir` (created when missing): root, cells, geometry, textures.
// `visibility` holds every cell in order. Only the format's own file names are written, below
// `dir`; an existing symbolic link in their place is refused. Errors: I/O, a texture the PTM
// encoder refuses, visibility not covering the cells.
Result<BuildStats> writeDatabase(const scene::Scene& scene, const Cells& cells,
                                 const std::vector<CellVisibility>& visibility,
                                 const VisibilityConfig& sampling, const std::string& sceneName,
                                 const std::string& dir);

// Joins part files into the visibility of every cell. Errors: cellCount outside 1..kMaxCells,
// parts of another scene (hash), sampling or cell count differing, a cell out of range, missing
// or covered twice.
Result<std::vector<CellVisibility>> mergeParts(const std::vector<PartFile>& parts,
                                               const std::string& sceneHash, uint32_t cellCount);

// Writes one file below dir (relative name checked with checkUrl; parents created; a symbolic
// link at the path or a parent refused).
Status writeBelow(const std::string& dir, const std::string& relative,
                  std::span<const uint8_t> bytes);

}  // namespace plx::stream
