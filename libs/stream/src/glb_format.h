#pragma once
// The glTF 2.0 binary constants the database's writer and reader share (Khronos glTF 2.0,
// "GLB File Format Specification" and "Accessor Data Types").

#include <cstdint>

namespace plx::stream::glb {

constexpr uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;   // "BIN\0"
constexpr int kFloat = 5126, kUnsignedInt = 5125;

}  // namespace plx::stream::glb
