// libFuzzer target: the isolated import's decoder of the scene the child process sends back
// (libs/scene/src/scene_wire.h). The child ran a third-party parser on a hostile file, so the
// parent treats these bytes as untrusted: errors only, never a crash, a hang, an out-of-bounds
// read or an allocation larger than the bytes justify.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "scene_wire.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    auto decoded = plx::scene::wire::decode(std::span<const uint8_t>(data, size));
    if (!decoded.isOk() && decoded.status().message().empty()) std::abort();
    // What the parent does next: finalize the scene, which checks what the bytes mean.
    if (decoded.isOk() && decoded->outcome == plx::scene::wire::WireOutcome::kScene)
        (void)decoded->scene.finalize();
    return 0;
}
