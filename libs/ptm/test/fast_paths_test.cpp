// Every SIMD path this machine can run against the scalar path, in-process (setActiveIsa): each
// ISA's vector passes against their scalar loops (fast_paths.inl, compiled per ISA), and each
// ISA's encoder and decoder, on valid and on damaged files, against the scalar ISA's.

#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <plx/core/cpu.h>
#include <plx/ptm/ptm.h>

#include "fast_paths.h"
#include "hostile_files.h"

namespace plx::ptm {
namespace {

using ReportFn = detail::PassReport (*)();

struct Check {
    const char* name;
    ReportFn (*pick)();
    bool vectorOnAvx2;  // an avx2 or avx512 ISA must run vector code in it
};

// The entries of the active ISA (PLX_ISA_PICK resolves at the call).
const Check kChecks[] = {
    {"prepareRow", [] { using namespace detail; return PLX_ISA_PICK(prepareRowReport); }, true},
    {"codeFullRow", [] { using namespace detail; return PLX_ISA_PICK(codeRowReport); }, true},
    {"fullRunContexts", [] { using namespace detail; return PLX_ISA_PICK(runContextsReport); },
     true},
    {"epsContexts", [] { using namespace detail; return PLX_ISA_PICK(epsContextsReport); }, true},
    {"finishFullRow", [] { using namespace detail; return PLX_ISA_PICK(finishRowReport); }, true},
    {"range check edges",
     [] { using namespace detail; return PLX_ISA_PICK(finishRowEdgesReport); }, true},
    {"extra bits", [] { using namespace detail; return PLX_ISA_PICK(extraBitsReport); }, true},
    {"rANS rounds", [] { using namespace detail; return PLX_ISA_PICK(ransRunsReport); }, true},
    {"small alphabets", [] { using namespace detail; return PLX_ISA_PICK(smallAlphabetReport); },
     false},
};

TEST(PtmFastPaths, EveryIsaPassMatchesItsScalarLoop) {
    ActiveIsaGuard restore;
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        for (const Check& check : kChecks) {
            const detail::PassReport r = check.pick()();
            const std::string where = std::string(isaName(isa)) + ", " + check.name;
            EXPECT_EQ(r.failures, 0) << where << ": " << r.first;
            if (isa != Isa::kScalar && check.vectorOnAvx2) {
                EXPECT_GT(r.vectorCases, 0) << where;
            }
        }
    }
}

ByteImage randomImage(int w, int h, int c, uint32_t seed) {
    std::mt19937 rng(seed);
    ByteImage img{w, h, c, std::vector<uint8_t>(size_t(w) * size_t(h) * size_t(c))};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < c; ++k)
                img.pixel(x, y)[k] = uint8_t((x * 5 + y * 3 + k * 50 + int(rng() % 13)) & 255);
    return img;
}

// What a decode gives: the levels, or the error message.
std::string outcome(const std::vector<uint8_t>& file) {
    auto levels = decodeAllLevels(file);
    if (!levels) return "error: " + levels.status().message();
    std::string bytes;
    for (const ByteImage& level : *levels) bytes.append(level.bytes.begin(), level.bytes.end());
    return bytes;
}

TEST(PtmFastPaths, EveryIsaEncodesAndDecodesAsScalar) {
    ActiveIsaGuard restore;
    const std::pair<int, int> sizes[] = {{1, 1}, {7, 3}, {33, 17}, {70, 9}, {130, 66}};
    for (auto [w, h] : sizes)
        for (int c = 1; c <= 4; ++c)
            for (int shape : {-1, 0, 4}) {
                const ByteImage img = randomImage(w, h, c, uint32_t(w * 7 + h + c));
                EncodeConfig cfg;
                cfg.shapeEighths = shape;
                ASSERT_TRUE(setActiveIsa(Isa::kScalar).isOk());
                auto reference = encode(img, cfg);
                ASSERT_TRUE(reference.isOk()) << reference.status().toString();
                const std::string decoded = outcome(*reference);
                // Damaged groups with valid checksums: the same levels or the same error.
                auto header = parseHeader(*reference);
                ASSERT_TRUE(header.isOk());
                std::vector<std::vector<uint8_t>> damaged;
                std::vector<std::string> damagedOutcome;
                for (int k = 0; k < header->levelCount; ++k)
                    for (size_t at : {size_t(3), size_t(40), size_t(333)}) {
                        damaged.push_back(corruptGroup(*reference, k, at, 0x5A));
                        damagedOutcome.push_back(outcome(damaged.back()));
                    }
                for (Isa isa : runnableIsas()) {
                    ASSERT_TRUE(setActiveIsa(isa).isOk());
                    const std::string where = std::string(isaName(isa)) + ", " +
                                              std::to_string(w) + "x" + std::to_string(h) +
                                              "x" + std::to_string(c) + ", shape " +
                                              std::to_string(shape);
                    auto file = encode(img, cfg);
                    ASSERT_TRUE(file.isOk()) << where;
                    EXPECT_EQ(*file, *reference) << where;
                    EXPECT_EQ(outcome(*file), decoded) << where;
                    for (size_t i = 0; i < damaged.size(); ++i)
                        EXPECT_EQ(outcome(damaged[i]), damagedOutcome[i]) << where << ", " << i;
                }
            }
}

}  // namespace
}  // namespace plx::ptm
