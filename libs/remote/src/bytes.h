#pragma once
// Little-endian byte writer and a bounds-checked reader for untrusted bytes. The reader never
// reads past its span; a failed read records a one-line error naming the field and leaves every
// later read failing, so a decoder checks ok() once per step instead of after every field.

#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include <plx/core/math.h>
#include <plx/core/status.h>

namespace plx::remote {

class ByteWriter {
public:
    explicit ByteWriter(std::vector<uint8_t>* out) : mOut(out) {}
    void u8(uint8_t v) { mOut->push_back(v); }
    void u16(uint16_t v) { putLe(v, 2); }
    void u32(uint32_t v) { putLe(v, 4); }
    void u64(uint64_t v) { putLe(v, 8); }
    void f32(float v) {
        uint32_t bits;
        std::memcpy(&bits, &v, 4);
        u32(bits);
    }
    void vec3(const Vec3& v) {
        f32(v.x);
        f32(v.y);
        f32(v.z);
    }
    void bytes(std::span<const uint8_t> b) { mOut->insert(mOut->end(), b.begin(), b.end()); }
    size_t size() const { return mOut->size(); }
    // Overwrites a u32 written earlier at `at` (a length known only after its payload).
    void patchU32(size_t at, uint32_t v) {
        for (int i = 0; i < 4; ++i) (*mOut)[at + size_t(i)] = uint8_t(v >> (8 * i));
    }

private:
    void putLe(uint64_t v, int n) {
        for (int i = 0; i < n; ++i) mOut->push_back(uint8_t(v >> (8 * i)));
    }
    std::vector<uint8_t>* mOut;
};

class ByteReader {
public:
    // context prefixes every error ("reference view", "pose message").
    ByteReader(std::span<const uint8_t> bytes, std::string context)
        : mBytes(bytes), mContext(std::move(context)) {}

    bool ok() const { return mStatus.isOk(); }
    const Status& status() const { return mStatus; }
    size_t left() const { return mBytes.size() - mPos; }
    size_t position() const { return mPos; }

    uint8_t u8(const char* field) { return uint8_t(getLe(field, 1)); }
    uint16_t u16(const char* field) { return uint16_t(getLe(field, 2)); }
    uint32_t u32(const char* field) { return uint32_t(getLe(field, 4)); }
    uint64_t u64(const char* field) { return getLe(field, 8); }
    // A finite float; NaN and infinities fail naming the field.
    float f32(const char* field) {
        const uint32_t bits = u32(field);
        float v;
        std::memcpy(&v, &bits, 4);
        if (ok() && !std::isfinite(v)) fail(ErrorCode::kCorruptData, "{} is not finite", field);
        return ok() ? v : 0.0f;
    }
    Vec3 vec3(const char* field) {
        const float x = f32(field), y = f32(field), z = f32(field);
        return {x, y, z};
    }
    // `n` bytes as a span into the input (no copy); fails when fewer are left.
    std::span<const uint8_t> bytes(const char* field, size_t n) {
        if (!ok()) return {};
        if (n > left()) {
            fail(ErrorCode::kCorruptData, "{} of {} bytes past the end ({} left)", field, n,
                 left());
            return {};
        }
        auto s = mBytes.subspan(mPos, n);
        mPos += n;
        return s;
    }
    // Fails unless every byte was read.
    void expectEnd() {
        if (ok() && left() != 0) fail(ErrorCode::kCorruptData, "{} trailing bytes", left());
    }
    // Records the first error only.
    template <class... Args>
    void fail(ErrorCode code, fmt::format_string<Args...> f, Args&&... args) {
        if (!ok()) return;
        mStatus = Status(code, mContext + ": " + fmt::format(f, std::forward<Args>(args)...));
        mPos = mBytes.size();
    }

private:
    uint64_t getLe(const char* field, int n) {
        if (!ok()) return 0;
        if (left() < size_t(n)) {
            fail(ErrorCode::kCorruptData, "truncated at {} (need {} bytes, {} left)", field, n,
                 left());
            return 0;
        }
        uint64_t v = 0;
        for (int i = 0; i < n; ++i) v |= uint64_t(mBytes[mPos + size_t(i)]) << (8 * i);
        mPos += size_t(n);
        return v;
    }

    std::span<const uint8_t> mBytes;
    std::string mContext;
    size_t mPos = 0;
    Status mStatus;
};

}  // namespace plx::remote
