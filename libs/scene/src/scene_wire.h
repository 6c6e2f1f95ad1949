#pragma once
// The compact binary form in which an isolated import's child process hands its scene (or its
// error) back to the parent. Both ends are the same build on the same machine, so values are in
// native byte order; the parent still treats the bytes as untrusted (the child ran a parser on a
// hostile file): every count is checked against the bytes left before anything is allocated.
//
// Layout: "PLXSCNW1" (8 bytes), u8 outcome (WireOutcome), then
//   kError / kOutOfMemory: u32 ErrorCode, string message;
//   kScene: u64 degenerateTrianglesDropped, u64 texturesMissing, u64 n + n warning strings,
//     u64 n + n meshes (string name, i32 materialIndex, arrays positions, normals, uvs, indices),
//     u64 n + n materials (string name, 4 f32 baseColor, i32 baseColorTexture),
//     u64 n + n textures (string name, u32 mip count, per mip i32 width, i32 height, RGBA8 texels),
//     u64 n + n viewpoints (string name, 3 f32 eyePos, targetPos, upDir, f32 fovYDegrees).
// A string is u64 length + bytes; an array is u64 element count + the elements' bytes. The
// message ends exactly after the last field.

#include <cstdint>
#include <functional>
#include <span>

#include <plx/scene/scene.h>

namespace plx::scene::wire {

enum class WireOutcome : uint8_t { kScene = 0, kError = 1, kOutOfMemory = 2 };

// Receives the encoded bytes in order; returns false to stop (the reader went away).
using Sink = std::function<bool(const void* bytes, size_t size)>;

// Encodes a scene; false when the sink refused bytes.
bool encodeScene(const Scene& scene, const Sink& sink);
// Encodes a failed import (outcome kError or kOutOfMemory) with its code and message.
bool encodeError(WireOutcome outcome, const Status& status, const Sink& sink);

// What the parent decoded: a scene, or the child's error and whether it ran out of memory.
struct Decoded {
    WireOutcome outcome = WireOutcome::kError;
    Status status;  // the child's error (outcome != kScene)
    Scene scene;    // not yet finalized (outcome == kScene)
};

// Decodes untrusted bytes; errors name the field that was malformed. Every count is checked
// against the bytes, not the scene's meaning: the caller must finalize the scene, which checks
// indices, material and texture references and finiteness (and is then done once, in the
// parent, not also in the child that sent it).
Result<Decoded> decode(std::span<const uint8_t> bytes);

}  // namespace plx::scene::wire
