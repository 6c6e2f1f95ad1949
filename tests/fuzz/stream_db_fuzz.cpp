// libFuzzer target: the streaming database's readers (docs/stream-format.md) on arbitrary bytes.
// A streaming client downloads these files from any web server, so each must return a one-line
// error, never crash, hang or read out of bounds. The first byte picks the reader (0 root file,
// 1 cell file, 2 part file, 3 a cell's glTF binary geometry), the rest is the file.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>

#include <plx/stream/database.h>
#include <plx/stream/glb_reader.h>

namespace {

template <typename ResultT>
void requireOneLineError(const ResultT& parsed) {
    if (parsed.isOk()) return;
    const std::string& m = parsed.status().message();
    if (m.empty() || m.find('\n') != std::string::npos) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const std::span<const uint8_t> file(data + 1, size - 1);
    switch (data[0] % 4) {
        case 0: requireOneLineError(plx::stream::parseRoot(file)); break;
        case 1: requireOneLineError(plx::stream::parseCell(file)); break;
        case 2: requireOneLineError(plx::stream::parsePart(file)); break;
        default: requireOneLineError(plx::stream::parseGlb(file)); break;
    }
    return 0;
}
