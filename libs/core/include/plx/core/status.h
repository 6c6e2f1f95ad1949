#pragma once
// Status and Result<T>: the error tiers 2 and 3 of ARCHITECTURE.md (untrusted input, environment).
// No exceptions cross library boundaries; a failed operation returns a code and a message that
// names the problem in one line.

#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

#include <plx/core/check.h>

namespace plx {

enum class ErrorCode {
    kOk = 0,
    kInvalidArgument,  // a parameter out of its documented range
    kNotFound,         // a file, scene or named item that does not exist
    kIoError,          // reading or writing failed
    kCorruptData,      // bytes that do not follow their format
    kUnsupported,      // a valid request this build cannot serve
    kOutOfRange,       // sizes or counts beyond what Parallax accepts
    kInternal,
};

// Short lower-case name of a code, e.g. "invalid argument".
const char* errorCodeName(ErrorCode code);

class [[nodiscard]] Status {
public:
    Status() = default;
    // A failed status's message is kept to one line whatever it quotes: control characters
    // (a newline in a name read from a file, say) become '?'.
    Status(ErrorCode code, std::string message);
    static Status ok() { return {}; }

    bool isOk() const { return mCode == ErrorCode::kOk; }
    explicit operator bool() const { return isOk(); }
    ErrorCode code() const { return mCode; }
    const std::string& message() const { return mMessage; }
    // "corrupt data: PNG header truncated"
    std::string toString() const;

private:
    ErrorCode mCode = ErrorCode::kOk;
    std::string mMessage;
};

// A value or a failed Status. value() on a failed result is a programmer error (aborts).
template <class T>
class [[nodiscard]] Result {
public:
    Result(T value) : mData(std::move(value)) {}  // NOLINT: implicit by design
    Result(Status status) : mData(std::move(status)) {
        PLX_CHECK(!std::get<Status>(mData).isOk());
    }

    bool isOk() const { return std::holds_alternative<T>(mData); }
    explicit operator bool() const { return isOk(); }
    const Status& status() const {
        static const Status kOkStatus;
        return isOk() ? kOkStatus : std::get<Status>(mData);
    }
    T& value() & {
        PLX_CHECK(isOk());
        return std::get<T>(mData);
    }
    const T& value() const& {
        PLX_CHECK(isOk());
        return std::get<T>(mData);
    }
    T&& value() && {
        PLX_CHECK(isOk());
        return std::get<T>(std::move(mData));
    }
    T* operator->() { return &value(); }
    const T* operator->() const { return &value(); }
    T& operator*() & { return value(); }
    const T& operator*() const& { return value(); }

private:
    std::variant<T, Status> mData;
};

// `text` with its control characters (newlines, tabs, escapes) as '?': the one line a message
// must be. A text over kMaxMessageChars bytes (a megabyte argument quoted back) keeps its first
// and last kMaxMessageChars / 2 bytes, cut at UTF-8 character boundaries, and says how many it
// left out between them.
inline constexpr size_t kMaxMessageChars = 4096;
std::string oneLine(std::string text);

// Untrusted text (a name from a file or the command line) as a message quotes it: printable
// ASCII, other bytes as '?', at most maxChars characters, then "...".
std::string printable(std::string_view text, size_t maxChars = 120);

inline Status errorStatus(ErrorCode code, std::string message) {
    return Status(code, std::move(message));
}

// Whether `value` lies in [first, last]. An enum cast from a number (a caller's configuration)
// may hold none of its enumerators; option checks refuse it rather than fall back to a default.
template <class Enum>
constexpr bool enumWithin(Enum value, Enum first, Enum last) {
    using Number = std::underlying_type_t<Enum>;
    return Number(value) >= Number(first) && Number(value) <= Number(last);
}

}  // namespace plx

// Returns early from the enclosing function when a Status-returning expression fails.
#define PLX_RETURN_IF_ERROR(expr)              \
    do {                                       \
        ::plx::Status plxStatus_ = (expr);     \
        if (!plxStatus_.isOk()) return plxStatus_; \
    } while (0)
