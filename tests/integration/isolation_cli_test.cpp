// Isolated import as a user meets it (issue 28): model files that crash assimp give one line
// naming the file and what happened, with exit 1, because `parallax` parses models in a limited
// child process by default. The files were observed to crash before isolation; each is written
// here, in a scratch folder.

#include <cstdlib>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

fs::path isolationDir() {
    return plx::testing::scratchDir("isolation_cli");
}

void le(std::string* s, uint32_t x, int bytes) {
    for (int k = 0; k < bytes; ++k) s->push_back(char(x >> (8 * k)));
}

uint32_t crc32(const std::string& data) {
    uint32_t crc = 0xFFFFFFFFu;
    for (unsigned char c : data) {
        crc ^= c;
        for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

// A zip archive of stored (uncompressed) entries: local headers, central directory, end record.
std::string storedZip(const std::vector<std::pair<std::string, std::string>>& entries) {
    std::string zip, central;
    for (const auto& [name, data] : entries) {
        uint32_t offset = uint32_t(zip.size()), crc = crc32(data), size = uint32_t(data.size());
        le(&zip, 0x04034b50, 4);
        for (uint32_t v : {20u, 0u, 0u, 0u, 0x21u}) le(&zip, v, 2);  // version ... date
        for (uint32_t v : {crc, size, size}) le(&zip, v, 4);
        le(&zip, uint32_t(name.size()), 2);
        le(&zip, 0, 2);
        zip += name + data;
        le(&central, 0x02014b50, 4);
        for (uint32_t v : {20u, 20u, 0u, 0u, 0u, 0x21u}) le(&central, v, 2);
        for (uint32_t v : {crc, size, size}) le(&central, v, 4);
        for (uint32_t v : {uint32_t(name.size()), 0u, 0u, 0u, 0u}) le(&central, v, 2);
        le(&central, 0, 4);
        le(&central, offset, 4);
        central += name;
    }
    uint32_t centralOffset = uint32_t(zip.size());
    zip += central;
    le(&zip, 0x06054b50, 4);
    for (uint32_t v : {0u, 0u, uint32_t(entries.size()), uint32_t(entries.size())}) le(&zip, v, 2);
    le(&zip, uint32_t(central.size()), 4);
    le(&zip, centralOffset, 4);
    le(&zip, 0, 2);
    return zip;
}

// A one-triangle 3MF package.
std::string triangle3mf() {
    return storedZip({
        {"[Content_Types].xml",
         R"(<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types"><Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>)"},
        {"_rels/.rels",
         R"(<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>)"},
        {"3D/3dmodel.model",
         R"(<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"><resources><object id="1" type="model"><mesh><vertices><vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/><vertex x="0" y="1" z="0"/></vertices><triangles><triangle v1="0" v2="1" v3="2"/></triangles></mesh></object></resources><build><item objectid="1"/></build></model>)"},
    });
}

// A one-triangle ASE file whose face line holds the given corners.
std::string triangleAse(const std::string& corners) {
    return "*3DSMAX_ASCIIEXPORT\t200\n*GEOMOBJECT {\n\t*NODE_NAME \"tri\"\n\t*MESH {\n"
           "\t\t*TIMEVALUE 0\n\t\t*MESH_NUMVERTEX 3\n\t\t*MESH_NUMFACES 1\n"
           "\t\t*MESH_VERTEX_LIST {\n\t\t\t*MESH_VERTEX 0\t0.0\t0.0\t0.0\n"
           "\t\t\t*MESH_VERTEX 1\t1.0\t0.0\t0.0\n\t\t\t*MESH_VERTEX 2\t0.0\t1.0\t0.0\n\t\t}\n"
           "\t\t*MESH_FACE_LIST {\n\t\t\t*MESH_FACE 0: " +
           corners + " AB: 1 BC: 1 CA: 1\n\t\t}\n\t}\n}\n";
}

TEST(IsolationCli, AseWithAHugeIndexIsOneLine) {
    fs::path good = isolationDir() / "good.ase", bad = isolationDir() / "huge_index.ase";
    writeFile(good, triangleAse("A: 0 B: 1 C: 2"));
    writeFile(bad, triangleAse("A: 0 B: 2147483647 C: 2"));
    EXPECT_EQ(runParallax("info " + q(good)).exitCode, 0);
    expectOneLineError(runParallax("info " + q(bad)),
                       "huge_index.ase: crashed (segmentation fault) while importing");
}

TEST(IsolationCli, Damaged3mfArchivesAreOneLineEach) {
    const std::string good = triangle3mf();
    writeFile(isolationDir() / "good.3mf", good);
    RunResult ok = runParallax("info " + q(isolationDir() / "good.3mf"));
    EXPECT_EQ(ok.exitCode, 0) << ok.err;
    // Every 16th byte inverted: about half of these made assimp abort on an internal assertion.
    int crashes = 0;
    for (size_t i = 0; i < good.size(); i += 16) {
        std::string bytes = good;
        bytes[i] = char(~bytes[i]);
        fs::path p = isolationDir() / "flipped.3mf";
        writeFile(p, bytes);
        RunResult r = runParallax("info " + q(p));
        if (r.exitCode == 0) continue;  // a byte the reader does not need
        expectOneLineError(r, "flipped.3mf: ");
        crashes += r.err.find("crashed") != std::string::npos;
    }
    EXPECT_GT(crashes, 0);
}

TEST(IsolationCli, InfoIsolatesByDefault) {
    // The fault hook runs only in the import's child process: seeing it proves there is one.
    setenv("PLX_TEST_IMPORT_FAULT", "segv", 1);
    fs::path model = fs::path(PLX_SOURCE_DIR) / "libs/scene/test/fixtures/tiny.obj";
    RunResult isolated = runParallax("info " + q(model));
    RunResult inProcess = runParallax("info --no-isolate " + q(model));
    unsetenv("PLX_TEST_IMPORT_FAULT");
    expectOneLineError(isolated, "tiny.obj: crashed (segmentation fault) while importing");
    EXPECT_EQ(inProcess.exitCode, 0) << inProcess.err;
}

TEST(IsolationCli, LimitsAreOptions) {
    setenv("PLX_TEST_IMPORT_FAULT", "spin", 1);
    fs::path model = fs::path(PLX_SOURCE_DIR) / "libs/scene/test/fixtures/tiny.obj";
    RunResult r = runParallax("info --import-seconds 0.5 " + q(model));
    unsetenv("PLX_TEST_IMPORT_FAULT");
    expectOneLineError(r, "took longer than 0.5 s");
    expectOneLineError(runParallax("info --import-memory 1 " + q(model)), "--import-memory", 2);
}

}  // namespace
