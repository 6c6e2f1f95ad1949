// White-box tests of the walker's vector passes (src/fast_codec.h, src/simd_codec.h; AVX2 and,
// where the build has it, AVX-512): each must give exactly what its scalar reference gives, on
// random rows of every length around the vector width, with values over the ranges a corrupt
// level can reach (not only those of valid levels). Encoder and decoder run the same passes, so
// the round trips alone would not see a vector path that both share.

#include <algorithm>
#include <functional>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "fast_codec.h"
#include "simd_codec.h"

namespace plx::ptm::detail {
namespace {

constexpr int kComps = 3;
// Row lengths below, at and around one and several vector steps (16 blocks).
constexpr int kLengths[] = {1, 2, 15, 16, 17, 31, 32, 33, 35, 47, 64, 100, 257};

struct Filler {
    std::mt19937 rng;
    int between(int lo, int hi) { return lo + int(rng() % uint32_t(hi - lo + 1)); }
    // Half the values over the whole range, half near zero, where the context thresholds are.
    void fill(std::vector<Lane>& v, int lo, int hi) {
        for (Lane& x : v)
            x = Lane(rng() % 2 ? between(lo, hi) : between(std::max(lo, -8), std::min(hi, 24)));
    }
    void fill(std::vector<uint8_t>& v) {
        for (uint8_t& x : v) x = uint8_t(rng());
    }
};

// Rows with every value a corrupt level can produce (fast_codec.h, `Lane`).
FastRows randomRows(int lw, const WalkModels& models, uint32_t seed) {
    FastRows R(kComps, lw, models);
    Filler f{std::mt19937(seed)};
    for (auto* v : {&R.pu, &R.pm, &R.pd, &R.v0, &R.v1, &R.v2, &R.m}) f.fill(*v, 0, 255);
    for (auto* v : {&R.u0, &R.u1, &R.u2, &R.u3}) f.fill(*v, -510, 893);
    f.fill(R.prevAct, 0, 384);
    for (auto* v : {&R.prevEA, &R.prevEB, &R.errA, &R.errB}) f.fill(*v, 0, 2700);
    for (auto* v : {&R.detail01, &R.detail11}) f.fill(*v, -1020, 1275);
    f.fill(R.act0, 0, 2040);
    f.fill(R.sel, 0, 1);
    f.fill(R.r3, -3400, 3400);
    for (auto* v : {&R.z0, &R.z1, &R.z2, &R.ze}) f.fill(*v);
    for (auto* v : {&R.z0, &R.z1, &R.z2})  // mostly small magnitudes, as real residuals
        for (uint8_t& z : *v) z = uint8_t(f.between(0, 3) ? z & 15 : z);
    // eps mostly valid, so that the range flags are not always raised.
    for (uint8_t& e : R.ze) e = uint8_t(f.between(0, 40) == 0 ? e : e & 3);
    return R;
}

void expectSameRows(const FastRows& a, const FastRows& b, const std::string& what) {
    auto same = [&](const auto& x, const auto& y, const char* name) {
        EXPECT_EQ(x, y) << what << ": " << name << " differs";
    };
    same(a.m, b.m, "m");
    same(a.u0, b.u0, "u0");
    same(a.u1, b.u1, "u1");
    same(a.u2, b.u2, "u2");
    same(a.u3, b.u3, "u3");
    same(a.act0, b.act0, "act0");
    same(a.sel, b.sel, "sel");
    same(a.v3, b.v3, "v3");
    same(a.detail01, b.detail01, "detail01");
    same(a.detail11, b.detail11, "detail11");
    same(a.curAct, b.curAct, "curAct");
    same(a.curEA, b.curEA, "curEA");
    same(a.curEB, b.curEB, "curEB");
    same(a.r3, b.r3, "r3");
    same(a.ctx, b.ctx, "ctx");
}

// The context maps a decoder builds (decoder.cpp): g tables for R raw contexts, g dividing R.
std::vector<CtxMap> decoderMaps(int raw) {
    std::vector<CtxMap> maps{rawCtxMap(1, 2)};
    for (int g = 1; g <= raw; ++g)
        if (raw % g == 0) maps.push_back({37, raw == 16 ? 512 * g : 683 * g});
    return maps;
}

const WalkModels kModels[] = {
    {false, false, 4}, {true, false, 4}, {true, true, 0}, {true, true, 3}, {true, true, 4}};

std::string label(int lw, int c, int modelIndex) {
    return "lw " + std::to_string(lw) + ", c " + std::to_string(c) + ", models " +
           std::to_string(modelIndex);
}

// Calls f.template operator()<W>() for each lane width W of the passes written for several
// (prepareRowVec, codeFullRowVec): Lanes16 with AVX2, also Lanes32 with AVX-512; without AVX2
// once with W = void (the scalar loops alone).
template <class F>
void forEachWidth(F&& f) {
#if defined(__AVX2__)
    f.template operator()<Lanes16>();
#if PLX_PTM_AVX512
    f.template operator()<Lanes32>();
#endif
#else
    f.template operator()<void>();
#endif
}

template <class W>
std::string widthName() {
    if constexpr (std::is_void_v<W>) return "scalar";
    else return std::to_string(W::kLanes) + " lanes";
}

TEST(PtmFastPaths, PrepareRowMatchesScalar) {
    forEachWidth([]<class W>() {
        uint32_t seed = 1;
        for (int lw : kLengths)
            for (int mi = 0; mi < 5; ++mi)
                for (int c = 0; c < kComps; ++c)
                    for (bool first : {false, true}) {
                        FastRows fast = randomRows(lw, kModels[mi], seed++), ref = fast;
                        if (kModels[mi].above) {
                            prepareRow<true, true, W>(fast, lw, c, first);
                            prepareRow<true, false>(ref, lw, c, first);
                        } else {
                            prepareRow<false, true, W>(fast, lw, c, first);
                            prepareRow<false, false>(ref, lw, c, first);
                        }
                        expectSameRows(fast, ref,
                                       label(lw, c, mi) + (first ? ", first row, " : ", ") +
                                           widthName<W>());
                    }
    });
}

template <class W, bool kEncode, bool kCross>
void codeRowCase(int lw, int c, int mi, uint32_t seed) {
    FastRows fast = randomRows(lw, kModels[mi], seed);
    if (kCross) {  // the earlier components' residuals as a decoded row leaves them (|r| <= 255)
        Filler f{std::mt19937(seed)};
        for (auto* v : {&fast.rA0, &fast.rA1, &fast.rA2}) f.fill(*v, -255, 255);
    }
    FastRows ref = fast;
    codeFullRow<kEncode, kCross, true, W>(fast, lw, lw, c);
    codeFullRow<kEncode, kCross, false>(ref, lw, lw, c);
    expectSameRows(fast, ref,
                   label(lw, c, mi) + (kEncode ? ", encode, " : ", decode, ") + widthName<W>());
    EXPECT_EQ(fast.v0, ref.v0);
    EXPECT_EQ(fast.v1, ref.v1);
    EXPECT_EQ(fast.v2, ref.v2);
    EXPECT_EQ(fast.z0, ref.z0);
    EXPECT_EQ(fast.z1, ref.z1);
    EXPECT_EQ(fast.z2, ref.z2);
    EXPECT_EQ(fast.errA, ref.errA);
    EXPECT_EQ(fast.errB, ref.errB);
    EXPECT_EQ(fast.rA0, ref.rA0);
    EXPECT_EQ(fast.rA1, ref.rA1);
    EXPECT_EQ(fast.rA2, ref.rA2);
}

// Prediction and reconstruction of the stored pixels, with the shapes a corrupt level can give.
TEST(PtmFastPaths, CodeRowMatchesScalar) {
    forEachWidth([]<class W>() {
        uint32_t seed = 5000;
        for (int lw : kLengths)
            for (int c = 0; c < kComps; ++c) {
                codeRowCase<W, true, false>(lw, c, 1, seed++);
                codeRowCase<W, false, false>(lw, c, 1, seed++);
                codeRowCase<W, true, true>(lw, c, 4, seed++);
                codeRowCase<W, false, true>(lw, c, 4, seed++);
            }
    });
}

template <class W, int kKind>
void runContextsCase(int lw, int full, int c, int mi, CtxMap map, uint32_t seed) {
    FastRows fast = randomRows(lw, kModels[mi], seed), ref = fast;
    fullRunContexts<kKind, true, W>(fast, lw, full, c, map);
    fullRunContexts<kKind, false>(ref, lw, full, c, map);
    expectSameRows(fast, ref,
                   label(lw, c, mi) + ", kind " + std::to_string(kKind) + ", " + widthName<W>());
}

TEST(PtmFastPaths, RunContextsMatchScalar) {
    forEachWidth([]<class W>() {
        uint32_t seed = 1000;
        for (int lw : kLengths)
            for (int full : {lw, lw - 1})
                for (int mi = 0; mi < 5; ++mi)
                    for (int c = 0; c < kComps; ++c)
                        for (const CtxMap& map : decoderMaps(kActivityBuckets)) {
                            if (full < 1) continue;
                            runContextsCase<W, 0>(lw, full, c, mi, map, seed++);
                            runContextsCase<W, 1>(lw, full, c, mi, map, seed++);
                            runContextsCase<W, 2>(lw, full, c, mi, map, seed++);
                        }
    });
}

TEST(PtmFastPaths, EpsContextsMatchScalar) {
    forEachWidth([]<class W>() {
        uint32_t seed = 2000;
        for (int lw : kLengths)
            for (int mi = 0; mi < 5; ++mi)
                for (int c = 0; c < kComps; ++c)
                    for (const CtxMap& map : decoderMaps(kEpsContexts)) {
                        FastRows fast = randomRows(lw, kModels[mi], seed++), ref = fast;
                        epsContexts<false, true, W>(fast, lw, lw, c, map);
                        epsContexts<false, false>(ref, lw, lw, c, map);
                        expectSameRows(fast, ref, label(lw, c, mi) + ", " + widthName<W>());
                    }
    });
}

template <class W, bool kKeepDetail, bool kCross>
void finishCase(int lw, int c, int mi, uint32_t seed) {
    FastRows fast = randomRows(lw, kModels[mi], seed), ref = fast;
    const unsigned badFast = finishFullRow<kKeepDetail, kCross, true, W>(fast, lw, lw, c);
    const unsigned badRef = finishFullRow<kKeepDetail, kCross, false>(ref, lw, lw, c);
    const std::string where = label(lw, c, mi) + ", " + widthName<W>();
    EXPECT_EQ(badFast != 0, badRef != 0) << where;
    expectSameRows(fast, ref, where);
}

TEST(PtmFastPaths, FinishRowMatchesScalar) {
    forEachWidth([]<class W>() {
        uint32_t seed = 3000;
        int flagged = 0, clean = 0;
        for (int lw : kLengths)
            for (int c = 0; c < kComps; ++c)
                for (int rep = 0; rep < 4; ++rep) {
                    finishCase<W, false, false>(lw, c, 0, seed++);
                    finishCase<W, true, false>(lw, c, 1, seed++);
                    finishCase<W, true, true>(lw, c, 4, seed++);
                    // Both outcomes of the range check occur among these rows.
                    FastRows rows = randomRows(lw, kModels[4], seed++);
                    (finishFullRow<true, true, false>(rows, lw, lw, c) ? flagged : clean)++;
                }
        EXPECT_GT(flagged, 0);
        EXPECT_GT(clean, 0);
    });
}

// eq. (3)'s range check at its edges: one block of an otherwise valid row gives p11 = -1, 0, 255
// or 256 (4 m + eps - v0 - v1 - v2), at every position of the row.
TEST(PtmFastPaths, FinishRowRangeCheckAtItsEdges) {
    forEachWidth([]<class W>() {
        for (int lw : {16, 33, 47, 64, 70})
            for (int at = 0; at < lw; ++at)
                for (const int last : {-1, 0, 255, 256}) {
                    FastRows fast = randomRows(lw, kModels[4], uint32_t(4000 + at));
                    const int c = 1;
                    for (int bx = 0; bx < lw; ++bx) {  // p11 = m + eps, valid
                        const size_t i = size_t(c * lw + bx);
                        fast.m[i] = fast.v0[i] = fast.v1[i] = fast.v2[i] = Lane(bx % 200);
                        fast.ze[i] = uint8_t(bx % 4);
                    }
                    const size_t i = size_t(c * lw + at);
                    fast.m[i] = last > 128 ? 64 : 0;  // 4 m - (v0 + v1 + v2) = last, eps = 0
                    fast.v0[i] = Lane(last == 255 || last == -1 ? 1 : 0);
                    fast.v1[i] = fast.v2[i] = 0;
                    fast.ze[i] = 0;
                    FastRows ref = fast;
                    const bool expectBad = last < 0 || last > 255;
                    const bool badFast = finishFullRow<true, true, true, W>(fast, lw, lw, c) != 0;
                    const bool badRef = finishFullRow<true, true, false>(ref, lw, lw, c) != 0;
                    EXPECT_EQ(badFast, expectBad) << "lw " << lw << ", block " << at << ", p11 "
                                                  << last << ", " << widthName<W>();
                    EXPECT_EQ(badRef, expectBad);
                }
    });
}

// The tokens' values from their extra bits (SimdDecodeIO::run), 16 or 32 per vector step against
// the scalar take() loop: every start bit within a byte, runs of several lengths, streams that
// end right after the bits (so that the vector path leaves the last ones to the scalar loop).
TEST(PtmFastPaths, ExtraBitsMatchScalar) {
#if defined(__AVX2__)
    using Reader = int (*)(uint8_t*, int, BitReader&);
    std::vector<std::pair<std::string, Reader>> readers = {{"16 tokens", &extraBitsAvx2}};
#if PLX_PTM_AVX512 && defined(__AVX512VBMI__)
    readers.push_back({"32 tokens", &extraBitsAvx512});
#endif
    for (const auto& [name, reader] : readers) {
        std::mt19937 rng(6000);
        int vectorTokens = 0;
        for (int n : {1, 15, 16, 17, 31, 32, 33, 48, 64, 100, 512})
            for (int start = 0; start < 12; ++start)
                for (int slack : {0, 1, 17, 40}) {
                    std::vector<uint8_t> tokens(static_cast<size_t>(n));
                    uint64_t needed = uint64_t(start);
                    for (uint8_t& t : tokens) {
                        t = uint8_t(rng() % 2 ? rng() % 16 : 16 + rng() % 8);
                        needed += kTokens.bits[t];
                    }
                    std::vector<uint8_t> stream(static_cast<size_t>(needed / 8 + 1) +
                                                size_t(slack));
                    for (uint8_t& b : stream) b = uint8_t(rng());
                    BitReader fastBits(stream.data(), stream.data() + stream.size());
                    BitReader refBits = fastBits;
                    fastBits.get(start);
                    refBits.get(start);
                    std::vector<uint8_t> fast = tokens, ref = tokens;
                    const int done = reader(fast.data(), n, fastBits);
                    vectorTokens += done;
                    for (int i = done; i < n; ++i) {
                        fastBits.ensure24();
                        fast[size_t(i)] = uint8_t(kTokens.base[fast[size_t(i)]] +
                                                  fastBits.take(kTokens.bits[fast[size_t(i)]]));
                    }
                    for (uint8_t& t : ref) {
                        refBits.ensure24();
                        t = uint8_t(kTokens.base[t] + refBits.take(kTokens.bits[t]));
                    }
                    EXPECT_EQ(fast, ref) << name << ", n " << n << ", start bit " << start
                                         << ", slack " << slack;
                    EXPECT_EQ(fastBits.position(), refBits.position()) << name;
                    EXPECT_TRUE(fastBits.exact(stream.size()) == refBits.exact(stream.size()));
                }
        EXPECT_GT(vectorTokens, 0) << name;
    }
#else
    GTEST_SKIP() << "no AVX2 in this build";
#endif
}

// Random frequency tables as a decoder may meet them: some tokens absent, one dominant token,
// and empty tables (every slot token 0, the state unchanged); tokens below `alphabet`.
std::vector<std::array<uint16_t, kTokenCount>> randomFrequencies(int tables, int alphabet,
                                                                 std::mt19937& rng) {
    std::vector<std::array<uint16_t, kTokenCount>> freqs(static_cast<size_t>(tables));
    for (int t = 0; t < tables; ++t) {
        if (t % 7 == 6) continue;  // empty
        std::array<uint32_t, kTokenCount> counts{};
        const int used = 1 + int(rng() % uint32_t(alphabet));
        for (int k = 0; k < used; ++k)
            counts[rng() % uint32_t(alphabet)] += k == 0 ? 1 + rng() % 5000 : 1 + rng() % 300;
        freqs[size_t(t)] = normalizeCounts(counts);
    }
    return freqs;
}

// A vector loop of SimdDecodeIO: decodes a prefix of a run, returns the symbols done.
using VectorLoop = std::function<int(SimdDecodeIO&, const uint16_t*, int, uint8_t*)>;

// Runs each loop (then the scalar tail) against the scalar decoder over tables `freqs`, with
// contexts drawn from tables first..first+count-1: tokens, states, stream position and overrun
// after two runs of every length around the 32-symbol round, on word streams that end early
// (the loops must leave the last 64 bytes to the checked reads).
[[maybe_unused]] void expectLoopsMatchScalar(
    const std::vector<std::array<uint16_t, kTokenCount>>& freqs, int first, int count,
    const std::vector<std::pair<std::string, VectorLoop>>& loops, std::mt19937& rng) {
    std::vector<uint32_t> entries(freqs.size() * kRansTotal);
    for (size_t t = 0; t < freqs.size(); ++t)
        buildSimdTable(freqs[t], entries.data() + t * kRansTotal);
    const std::array<std::array<int, 2>, 16> families{};
    int vectorSymbols = 0;
    for (int n : {1, 31, 32, 33, 64, 95, 512, 700})
        for (int words : {16, 40, 200, 5000}) {
            std::vector<uint8_t> stream(static_cast<size_t>(2 * words));
            for (uint8_t& b : stream) b = uint8_t(rng());
            std::vector<uint16_t> ctx(static_cast<size_t>(n));
            for (uint16_t& c : ctx) c = uint16_t(first + int(rng() % uint32_t(count)));
            auto io = [&] {
                return SimdDecodeIO(entries.data(), families, kSimdStates, stream.data(),
                                    stream.data() + stream.size(), BitReader(nullptr, nullptr));
            };
            SimdDecodeIO ref = io();
            std::vector<uint8_t> refTokens(static_cast<size_t>(n));
            for (int pass = 0; pass < 2; ++pass)
                ref.run<false, false>(ctx.data(), n, refTokens.data());
            for (const auto& [name, loop] : loops) {
                SimdDecodeIO fast = io();
                std::vector<uint8_t> tokens(static_cast<size_t>(n));
                for (int pass = 0; pass < 2; ++pass) {  // the second starts from the first's states
                    const int done = loop(fast, ctx.data(), n, tokens.data());
                    vectorSymbols += done;
                    fast.runScalar(ctx.data(), done, n, tokens.data());
                }
                const std::string where =
                    name + ", n " + std::to_string(n) + ", words " + std::to_string(words);
                EXPECT_EQ(tokens, refTokens) << where;
                EXPECT_TRUE(std::equal(fast.x, fast.x + kSimdStates, ref.x)) << where;
                EXPECT_EQ(fast.ptr, ref.ptr) << where;
                EXPECT_EQ(fast.overrun, ref.overrun) << where;
            }
        }
    EXPECT_GT(vectorSymbols, 0);
}

// SimdDecodeIO::runVectorAvx2 and, in builds for AVX-512, runVectorAvx512 against the scalar
// decoder.
TEST(PtmFastPaths, RansRunsMatchScalar) {
#if defined(__AVX2__)
    std::mt19937 rng(7000);
    std::vector<std::pair<std::string, VectorLoop>> loops = {
        {"avx2", [](SimdDecodeIO& io, const uint16_t* c, int n, uint8_t* t) {
             return io.runVectorAvx2(c, n, t);
         }}};
#if PLX_PTM_AVX512
    loops.push_back({"avx512", [](SimdDecodeIO& io, const uint16_t* c, int n, uint8_t* t) {
                         return io.runVectorAvx512(c, n, t);
                     }});
#endif
    expectLoopsMatchScalar(randomFrequencies(40, kTokenCount, rng), 0, 40, loops, rng);
#else
    GTEST_SKIP() << "no AVX2 in this build";
#endif
}

// The eps runs' loop over tables of tokens 0..3 (SimdDecodeIO::runSmallAvx512) against the
// scalar decoder, for families of 1 to 16 tables (some empty, some without token 0 or 3),
// placed after other tables; and a family with a larger token is left to the table path.
TEST(PtmFastPaths, SmallAlphabetRunsMatchScalar) {
    std::mt19937 rng(8000);
    for (int count : {1, 2, 5, 15, 16}) {
        auto freqs = randomFrequencies(7 + count, 4, rng);
        SmallAlphabet family;
        family.build(freqs, 7, count);
        EXPECT_TRUE(family.usable) << count;
#if PLX_PTM_AVX512
        expectLoopsMatchScalar(
            freqs, 7, count,
            {{"small, " + std::to_string(count) + " tables",
              [&family](SimdDecodeIO& io, const uint16_t* c, int n, uint8_t* t) {
                  return io.runSmallAvx512(c, n, t, family);
              }}},
            rng);
#endif
        freqs[size_t(7 + count / 2)][4] = 1;  // a token above 3 (renormalised or not)
        family.build(freqs, 7, count);
        EXPECT_FALSE(family.usable) << count;
    }
    SmallAlphabet tooMany;
    tooMany.build(randomFrequencies(17, 4, rng), 0, 17);
    EXPECT_FALSE(tooMany.usable);
#if !PLX_PTM_AVX512
    GTEST_SKIP() << "the loop needs AVX-512; checked only which families may use it";
#endif
}

}  // namespace
}  // namespace plx::ptm::detail
