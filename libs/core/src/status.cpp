#include <cstdio>
#include <cstdlib>
#include <string>

#include <plx/core/check.h>
#include <plx/core/status.h>

namespace plx {

const char* errorCodeName(ErrorCode code) {
    switch (code) {
        case ErrorCode::kOk: return "ok";
        case ErrorCode::kInvalidArgument: return "invalid argument";
        case ErrorCode::kNotFound: return "not found";
        case ErrorCode::kIoError: return "i/o error";
        case ErrorCode::kCorruptData: return "corrupt data";
        case ErrorCode::kUnsupported: return "unsupported";
        case ErrorCode::kOutOfRange: return "out of range";
        case ErrorCode::kInternal: return "internal error";
    }
    return "unknown error";
}

namespace {
bool isUtf8Continuation(char c) {
    return (uint8_t(c) & 0xc0) == 0x80;
}
}  // namespace

std::string oneLine(std::string text) {
    for (char& c : text)
        if ((c >= 0 && c < 0x20) || c == 0x7f) c = '?';
    if (text.size() <= kMaxMessageChars) return text;
    size_t headEnd = kMaxMessageChars / 2, tailStart = text.size() - kMaxMessageChars / 2;
    while (headEnd > 0 && isUtf8Continuation(text[headEnd])) --headEnd;
    while (tailStart < text.size() && isUtf8Continuation(text[tailStart])) ++tailStart;
    return text.substr(0, headEnd) + " [... " + std::to_string(tailStart - headEnd) +
           " bytes left out ...] " + text.substr(tailStart);
}

Status::Status(ErrorCode code, std::string message)
    : mCode(code),
      mMessage(code == ErrorCode::kOk ? std::move(message) : oneLine(std::move(message))) {}

std::string printable(std::string_view text, size_t maxChars) {
    std::string out;
    for (char c : text.substr(0, maxChars)) out.push_back(c >= 0x20 && c < 0x7f ? c : '?');
    return text.size() > maxChars ? out + "..." : out;
}

std::string Status::toString() const {
    if (isOk()) return "ok";
    return std::string(errorCodeName(mCode)) + ": " + mMessage;
}

namespace detail {
void checkFailed(const char* condition, const char* file, int line) {
    std::fprintf(stderr, "PLX_CHECK failed: %s at %s:%d\n", condition, file, line);
    std::fflush(stderr);
    std::abort();
}
}  // namespace detail

}  // namespace plx
