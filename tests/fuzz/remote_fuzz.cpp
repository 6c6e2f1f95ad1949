// libFuzzer targets: the remote protocol decoder (PLX_REMOTE_FUZZ_VIEW undefined) or the
// reference-view decoder (defined) on arbitrary bytes. They must return errors, never crash,
// hang or read out of bounds. The limits keep valid but large views within libFuzzer's memory.

#include <cstddef>
#include <cstdint>
#include <span>

#include <plx/remote/codec.h>
#include <plx/remote/protocol.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    plx::remote::DecodeLimits limits;
    limits.maxViewSide = 512;
    limits.maxViewPixels = 512 * 512;
    limits.maxSetPixels = 4 * 512 * 512;
    const std::span<const uint8_t> bytes(data, size);
#ifdef PLX_REMOTE_FUZZ_VIEW
    plx::warp::ReferenceView view;
    (void)plx::remote::decodeReferenceView(bytes, limits, &view);
#else
    (void)plx::remote::decodeMessage(bytes, limits);
#endif
    return 0;
}
