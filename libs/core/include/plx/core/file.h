#pragma once
// Checked reading of untrusted input files: only regular files are read (a directory, FIFO,
// socket or device is refused without blocking), within a size limit, and a failure names the
// real cause (not found, permission, symlink loop, directory) without quoting the file's bytes.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <plx/core/status.h>

namespace plx {

// Default limit for whole-file reads: far above any input Parallax reads whole (models are read
// by assimp, not through here), low enough that a mistaken path cannot take all memory.
constexpr uint64_t kDefaultMaxFileBytes = uint64_t(1) << 32;

// Reads a whole regular file. The file is opened with O_NONBLOCK (a FIFO cannot stall the open)
// and checked with fstat on the opened descriptor (no race with a renamed path). Errors name the
// path and the cause; kOutOfRange when the file holds more than maxBytes.
Result<std::string> readFileChecked(const std::string& path,
                                    uint64_t maxBytes = kDefaultMaxFileBytes);

// Checks that path names a readable regular file without reading it: the same opening and
// messages as readFileChecked. Gives the file's size.
Result<uint64_t> checkRegularFile(const std::string& path);

// "line L, column C" (both from 1) of a byte offset into text, for parse errors: the position
// tells the user where to look without quoting the text. Offsets past the end give the end.
std::string lineColumn(std::string_view text, size_t byteOffset);

}  // namespace plx
