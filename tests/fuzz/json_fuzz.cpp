// libFuzzer targets: the display description parser (PLX_JSON_FUZZ_PATH undefined) or the
// stereo walkthrough pose-path parser (defined) on arbitrary bytes. Both read files a user may
// have downloaded; they must return one-line errors, never crash, hang or read out of bounds.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#ifdef PLX_JSON_FUZZ_PATH
#include <plx/stereo/path.h>
#else
#include <plx/display/display_json.h>
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
#ifdef PLX_JSON_FUZZ_PATH
    auto parsed = plx::stereo::parsePath(text);
#else
    auto parsed = plx::display::parseDisplayJson(text);
#endif
    // The CLI prints the message as one line: an empty or multi-line message is a bug too.
    if (!parsed.isOk()) {
        const std::string& m = parsed.status().message();
        if (m.empty() || m.find('\n') != std::string::npos) std::abort();
    }
    return 0;
}
