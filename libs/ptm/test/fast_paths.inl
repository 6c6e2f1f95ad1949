// The checks of fast_paths.h for one ISA: every vector pass of the PTM kernels (lanes of the
// widths this ISA has) must give exactly what its scalar loop gives, on random rows of every
// length around the vector width, with values over the ranges a corrupt level can reach (not
// only those of valid levels). Encoder and decoder run the same passes, so round trips alone
// would not see a vector path that both share.
#include <algorithm>
#include <array>
#include <cstdarg>
#include <cstdio>
#include <type_traits>

#include "decode_io.h"
#include "walker.h"

#include "fast_paths.h"

namespace plx::ptm::detail::PLX_ISA_NS {
namespace {

constexpr int kComps = 3;
// Row lengths below, at and around one and several vector steps (16 and 32 blocks).
constexpr int kLengths[] = {1, 2, 15, 16, 17, 31, 32, 33, 35, 47, 64, 100, 257};
// Shape weights (the group's mode byte) the rows are checked with.
constexpr int kShapes[] = {0, 3, 4};

// xorshift64*: the test's random numbers, a type of this ISA's namespace (as every template
// instantiation here should be, so that no ISA's copy is shared).
struct Rng {
    uint64_t state;
    explicit Rng(uint64_t seed) : state(seed * 0x9E3779B97F4A7C15ull + 1) {}
    uint32_t operator()() {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        return uint32_t((state * 0x2545F4914F6CDD1Dull) >> 32);
    }
};

// Counts a case; records the first failure, its description printf-style.
void expect(PassReport& r, bool ok, const char* format, ...) {
    ++r.cases;
    if (ok) return;
    if (r.failures++ > 0) return;
    va_list args;
    va_start(args, format);
    std::vsnprintf(r.first, sizeof r.first, format, args);
    va_end(args);
}

struct Filler {
    Rng rng;
    int between(int lo, int hi) { return lo + int(rng() % uint32_t(hi - lo + 1)); }
    // Half the values over the whole range, half near zero, where the context thresholds are.
    void fill(Row<Lane>& v, int lo, int hi) {
        for (Lane& x : v)
            x = Lane(rng() % 2 ? between(lo, hi) : between(std::max(lo, -8), std::min(hi, 24)));
    }
    void fill(Row<uint8_t>& v) {
        for (uint8_t& x : v) x = uint8_t(rng());
    }
};

// Rows with every value a corrupt level can produce (lanes.h, `Lane`).
LevelRows randomRows(int lw, int shapeEighths, uint32_t seed) {
    LevelRows R(kComps, lw, shapeEighths);
    Filler f{Rng(seed)};
    for (auto* v : {&R.pu, &R.pm, &R.pd, &R.v0, &R.v1, &R.v2, &R.m}) f.fill(*v, 0, 255);
    for (auto* v : {&R.u0, &R.u1, &R.u2, &R.u3}) f.fill(*v, -510, 893);
    f.fill(R.prevAct, 0, 384);
    for (auto* v : {&R.prevEA, &R.prevEB, &R.errA, &R.errB}) f.fill(*v, 0, 2700);
    for (auto* v : {&R.detail01, &R.detail11}) f.fill(*v, -1020, 1275);
    f.fill(R.act0, 0, 2040);
    f.fill(R.sel, 0, 1);
    f.fill(R.r3, -3400, 3400);
    for (auto* v : {&R.rA0, &R.rA1, &R.rA2}) f.fill(*v, -255, 255);
    for (auto* v : {&R.z0, &R.z1, &R.z2, &R.ze}) f.fill(*v);
    for (auto* v : {&R.z0, &R.z1, &R.z2})  // mostly small magnitudes, as real residuals
        for (uint8_t& z : *v) z = uint8_t(f.between(0, 3) ? z & 15 : z);
    // eps mostly valid, so that the range flags are not always raised.
    for (uint8_t& e : R.ze) e = uint8_t(f.between(0, 40) == 0 ? e : e & 3);
    return R;
}

// The name of the first row that differs, or nullptr.
const char* firstDifference(const LevelRows& a, const LevelRows& b) {
    const std::pair<const char*, bool> rows[] = {
        {"m", a.m == b.m},          {"u0", a.u0 == b.u0},       {"u1", a.u1 == b.u1},
        {"u2", a.u2 == b.u2},       {"u3", a.u3 == b.u3},       {"act0", a.act0 == b.act0},
        {"sel", a.sel == b.sel},    {"v0", a.v0 == b.v0},       {"v1", a.v1 == b.v1},
        {"v2", a.v2 == b.v2},       {"v3", a.v3 == b.v3},       {"z0", a.z0 == b.z0},
        {"z1", a.z1 == b.z1},       {"z2", a.z2 == b.z2},       {"errA", a.errA == b.errA},
        {"errB", a.errB == b.errB}, {"rA0", a.rA0 == b.rA0},    {"rA1", a.rA1 == b.rA1},
        {"rA2", a.rA2 == b.rA2},    {"r3", a.r3 == b.r3},       {"ctx", a.ctx == b.ctx},
        {"detail01", a.detail01 == b.detail01}, {"detail11", a.detail11 == b.detail11},
        {"curAct", a.curAct == b.curAct},       {"curEA", a.curEA == b.curEA},
        {"curEB", a.curEB == b.curEB}};
    for (const auto& [name, same] : rows)
        if (!same) return name;
    return nullptr;
}

void expectSameRows(PassReport& r, const LevelRows& fast, const LevelRows& ref, const char* pass,
                    int lw, int c, int lanes) {
    const char* row = firstDifference(fast, ref);
    expect(r, row == nullptr, "%s, lw %d, c %d, %d lanes: row %s differs", pass, lw, c, lanes,
           row ? row : "");
}

// The context maps a decoder builds (decoder.cpp): g tables for R raw contexts, g dividing R.
Row<CtxMap> decoderMaps(int raw) {
    Row<CtxMap> maps{rawCtxMap(1, 2)};
    for (int g = 1; g <= raw; ++g)
        if (raw % g == 0) maps.push_back({37, raw == 16 ? 512 * g : 683 * g});
    return maps;
}

// Calls f.template operator()<W>() for each lane width W this ISA has (Lanes16 with AVX2, also
// Lanes32 with AVX-512); without AVX2 once with W = void (the scalar loops against themselves).
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
constexpr int lanesOf() {
    if constexpr (std::is_void_v<W>)
        return 1;
    else
        return W::kLanes;
}

// Counts the vector cases of a width.
template <class W>
void countVector(PassReport& r, int cases) {
    if constexpr (!std::is_void_v<W>) r.vectorCases += cases;
}

// Random frequency tables as a decoder may meet them: some tokens absent, one dominant token,
// and empty tables (every slot token 0, the state unchanged); tokens below `alphabet`.
Row<std::array<uint16_t, kTokenCount>> randomFrequencies(int tables, int alphabet,
                                                                 Rng& rng) {
    Row<std::array<uint16_t, kTokenCount>> freqs(static_cast<size_t>(tables));
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

bool sameStates(const DecodeIO& a, const DecodeIO& b) {
    for (int i = 0; i < kSimdStates; ++i)
        if (a.x[i] != b.x[i]) return false;
    return true;
}

// Runs `loop` (a vector loop of DecodeIO, then the scalar tail) against the scalar decoder over
// tables `freqs`, with contexts drawn from tables first..first+count-1: tokens, states, stream
// position and overrun after two runs of every length around the 32-symbol round, on word
// streams that end early (the loops must leave the last 64 bytes to the checked reads).
template <class Loop>
void expectLoopMatchesScalar(PassReport& r, const char* name,
                             const Row<std::array<uint16_t, kTokenCount>>& freqs,
                             int first, int count, Loop loop, Rng& rng) {
    Row<uint32_t> entries(freqs.size() * kRansTotal);
    for (size_t t = 0; t < freqs.size(); ++t)
        buildSimdTable(freqs[t], entries.data() + t * kRansTotal);
    const std::array<std::array<int, 2>, 16> families{};
    for (int n : {1, 31, 32, 33, 64, 95, 512, 700})
        for (int words : {16, 40, 200, 5000}) {
            Row<uint8_t> stream(static_cast<size_t>(2 * words));
            for (uint8_t& b : stream) b = uint8_t(rng());
            Row<uint16_t> ctx(static_cast<size_t>(n));
            for (uint16_t& c : ctx) c = uint16_t(first + int(rng() % uint32_t(count)));
            auto io = [&] {
                return DecodeIO(entries.data(), families, kSimdStates, stream.data(),
                                stream.data() + stream.size(), BitReader(nullptr, nullptr));
            };
            DecodeIO ref = io(), fast = io();
            Row<uint8_t> refTokens(static_cast<size_t>(n)), tokens(refTokens);
            int done = 0;
            for (int pass = 0; pass < 2; ++pass) {  // the second starts from the first's states
                ref.run<false, false>(ctx.data(), n, refTokens.data());
                const int vector = loop(fast, ctx.data(), n, tokens.data());
                done += vector;
                fast.runScalar(ctx.data(), vector, n, tokens.data());
            }
            r.vectorCases += done > 0 ? 1 : 0;
            expect(r,
                   tokens == refTokens && sameStates(fast, ref) && fast.ptr == ref.ptr &&
                       fast.overrun == ref.overrun,
                   "%s, n %d, words %d: tokens, states or stream position differ", name, n,
                   words);
        }
}

}  // namespace

PassReport prepareRowReport() {
    PassReport r;
    forEachWidth([&r]<class W>() {
        uint32_t seed = 1;
        for (int lw : kLengths)
            for (int shape : kShapes)
                for (int c = 0; c < kComps; ++c)
                    for (bool first : {false, true})
                        for (bool above : {false, true}) {
                            LevelRows fast = randomRows(lw, shape, seed++), ref = fast;
                            if (above) {
                                prepareRow<true, true, W>(fast, lw, c, first);
                                prepareRow<true, false>(ref, lw, c, first);
                            } else {
                                prepareRow<false, true, W>(fast, lw, c, first);
                                prepareRow<false, false>(ref, lw, c, first);
                            }
                            expectSameRows(r, fast, ref, above ? "prepareRow above" : "prepareRow",
                                           lw, c, lanesOf<W>());
                            countVector<W>(r, lw >= lanesOf<W>() ? 1 : 0);
                        }
    });
    return r;
}

PassReport codeRowReport() {
    PassReport r;
    forEachWidth([&r]<class W>() {
        uint32_t seed = 5000;
        for (int lw : kLengths)
            for (int c = 0; c < kComps; ++c)
                for (bool encode : {true, false}) {
                    LevelRows fast = randomRows(lw, 4, seed++), ref = fast;
                    if (encode) {
                        codeFullRow<true, true, W>(fast, lw, lw, c);
                        codeFullRow<true, false>(ref, lw, lw, c);
                    } else {
                        codeFullRow<false, true, W>(fast, lw, lw, c);
                        codeFullRow<false, false>(ref, lw, lw, c);
                    }
                    expectSameRows(r, fast, ref, encode ? "codeFullRow encode" : "codeFullRow",
                                   lw, c, lanesOf<W>());
                    countVector<W>(r, lw >= lanesOf<W>() ? 1 : 0);
                }
    });
    return r;
}

PassReport runContextsReport() {
    PassReport r;
    forEachWidth([&r]<class W>() {
        uint32_t seed = 1000;
        for (int lw : kLengths)
            for (int full : {lw, lw - 1})
                for (int c = 0; c < kComps; ++c)
                    for (const CtxMap& map : decoderMaps(kActivityBuckets)) {
                        if (full < 1) continue;
                        auto one = [&]<int kKind>() {
                            LevelRows fast = randomRows(lw, 4, seed++), ref = fast;
                            fullRunContexts<kKind, true, W>(fast, lw, full, c, map);
                            fullRunContexts<kKind, false>(ref, lw, full, c, map);
                            expectSameRows(r, fast, ref, "fullRunContexts", lw, c, lanesOf<W>());
                            countVector<W>(r, full >= 16 ? 1 : 0);
                        };
                        one.template operator()<0>();
                        one.template operator()<1>();
                        one.template operator()<2>();
                    }
    });
    return r;
}

PassReport epsContextsReport() {
    PassReport r;
    forEachWidth([&r]<class W>() {
        uint32_t seed = 2000;
        for (int lw : kLengths)
            for (int c = 0; c < kComps; ++c)
                for (const CtxMap& map : decoderMaps(kEpsContexts)) {
                    LevelRows fast = randomRows(lw, 4, seed++), ref = fast;
                    epsContexts<false, true, W>(fast, lw, lw, c, map);
                    epsContexts<false, false>(ref, lw, lw, c, map);
                    expectSameRows(r, fast, ref, "epsContexts", lw, c, lanesOf<W>());
                    countVector<W>(r, lw >= lanesOf<W>() ? 1 : 0);
                }
    });
    return r;
}

PassReport finishRowReport() {
    PassReport r;
    forEachWidth([&r]<class W>() {
        uint32_t seed = 3000;
        int flagged = 0, clean = 0;
        for (int lw : kLengths)
            for (int c = 0; c < kComps; ++c)
                for (int rep = 0; rep < 8; ++rep) {
                    LevelRows fast = randomRows(lw, 4, seed++), ref = fast;
                    const unsigned badFast = finishFullRow<true, W>(fast, lw, lw, c);
                    const unsigned badRef = finishFullRow<false>(ref, lw, lw, c);
                    expect(r, (badFast != 0) == (badRef != 0),
                           "finishFullRow, lw %d, c %d, %d lanes: range flags differ", lw, c,
                           lanesOf<W>());
                    expectSameRows(r, fast, ref, "finishFullRow", lw, c, lanesOf<W>());
                    countVector<W>(r, lw >= lanesOf<W>() ? 1 : 0);
                    (badRef ? flagged : clean)++;
                }
        // Both outcomes of the range check occur among these rows.
        expect(r, flagged > 0 && clean > 0, "finishFullRow: %d rows flagged, %d clean", flagged,
               clean);
    });
    return r;
}

// eq. (3)'s range check at its edges: one block of an otherwise valid row gives p11 = -1, 0, 255
// or 256 (4 m + eps - v0 - v1 - v2), at every position of the row.
PassReport finishRowEdgesReport() {
    PassReport r;
    forEachWidth([&r]<class W>() {
        for (int lw : {16, 33, 47, 64, 70})
            for (int at = 0; at < lw; ++at)
                for (const int last : {-1, 0, 255, 256}) {
                    LevelRows fast = randomRows(lw, 4, uint32_t(4000 + at));
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
                    LevelRows ref = fast;
                    const bool expectBad = last < 0 || last > 255;
                    const bool badFast = finishFullRow<true, W>(fast, lw, lw, c) != 0;
                    const bool badRef = finishFullRow<false>(ref, lw, lw, c) != 0;
                    expect(r, badFast == expectBad && badRef == expectBad,
                           "range check, lw %d, block %d, p11 %d, %d lanes: %d / %d", lw, at, last,
                           lanesOf<W>(), int(badFast), int(badRef));
                    countVector<W>(r, 1);
                }
    });
    return r;
}

// The tokens' values from their extra bits (DecodeIO::run), 16 or 32 per vector step against the
// scalar take() loop: every start bit within a byte, runs of several lengths, streams that end
// right after the bits (so that the vector path leaves the last ones to the scalar loop).
PassReport extraBitsReport() {
    PassReport r;
#if defined(__AVX2__)
    using Reader = int (*)(uint8_t*, int, BitReader&);
    Row<std::pair<const char*, Reader>> readers = {{"16 tokens", &extraBitsAvx2}};
#if PLX_PTM_AVX512 && defined(__AVX512VBMI__)
    readers.push_back({"32 tokens", &extraBitsAvx512});
#endif
    for (const auto& [name, reader] : readers) {
        Rng rng(6000);
        for (int n : {1, 15, 16, 17, 31, 32, 33, 48, 64, 100, 512})
            for (int start = 0; start < 12; ++start)
                for (int slack : {0, 1, 17, 40}) {
                    Row<uint8_t> tokens(static_cast<size_t>(n));
                    uint64_t needed = uint64_t(start);
                    for (uint8_t& t : tokens) {
                        t = uint8_t(rng() % 2 ? rng() % 16 : 16 + rng() % 8);
                        needed += kTokens.bits[t];
                    }
                    Row<uint8_t> stream(static_cast<size_t>(needed / 8 + 1) +
                                                size_t(slack));
                    for (uint8_t& b : stream) b = uint8_t(rng());
                    BitReader fastBits(stream.data(), stream.data() + stream.size());
                    BitReader refBits = fastBits;
                    fastBits.get(start);
                    refBits.get(start);
                    Row<uint8_t> fast = tokens, ref = tokens;
                    const int done = reader(fast.data(), n, fastBits);
                    r.vectorCases += done > 0 ? 1 : 0;
                    for (int i = done; i < n; ++i) {
                        fastBits.ensure24();
                        fast[size_t(i)] = uint8_t(kTokens.base[fast[size_t(i)]] +
                                                  fastBits.take(kTokens.bits[fast[size_t(i)]]));
                    }
                    for (uint8_t& t : ref) {
                        refBits.ensure24();
                        t = uint8_t(kTokens.base[t] + refBits.take(kTokens.bits[t]));
                    }
                    expect(r,
                           fast == ref && fastBits.position() == refBits.position() &&
                               fastBits.exact(stream.size()) == refBits.exact(stream.size()),
                           "%s, n %d, start bit %d, slack %d: values or position differ", name, n,
                           start, slack);
                }
    }
#endif
    return r;
}

// DecodeIO::runVectorAvx2 and, with AVX-512, runVectorAvx512 against the scalar decoder.
PassReport ransRunsReport() {
    PassReport r;
#if defined(__AVX2__)
    Rng rng(7000);
    const auto freqs = randomFrequencies(40, kTokenCount, rng);
    expectLoopMatchesScalar(r, "avx2 rounds", freqs, 0, 40,
                            [](DecodeIO& io, const uint16_t* c, int n, uint8_t* t) {
                                return io.runVectorAvx2(c, n, t);
                            },
                            rng);
#if PLX_PTM_AVX512
    expectLoopMatchesScalar(r, "avx512 rounds", freqs, 0, 40,
                            [](DecodeIO& io, const uint16_t* c, int n, uint8_t* t) {
                                return io.runVectorAvx512(c, n, t);
                            },
                            rng);
#endif
#endif
    return r;
}

// The eps runs' loop over tables of tokens 0..3 (DecodeIO::runSmallAvx512) against the scalar
// decoder, for families of 1 to 16 tables (some empty, some without token 0 or 3), placed after
// other tables; and a family with a larger token is left to the table path.
PassReport smallAlphabetReport() {
    PassReport r;
    Rng rng(8000);
    for (int count : {1, 2, 5, 15, 16}) {
        auto freqs = randomFrequencies(7 + count, 4, rng);
        SmallAlphabet family;
        family.build(freqs, 7, count);
        expect(r, family.usable, "a family of %d tables of tokens 0..3 is not usable", count);
#if PLX_PTM_AVX512
        expectLoopMatchesScalar(r, "small alphabet", freqs, 7, count,
                                [&family](DecodeIO& io, const uint16_t* c, int n, uint8_t* t) {
                                    return io.runSmallAvx512(c, n, t, family);
                                },
                                rng);
#endif
        freqs[size_t(7 + count / 2)][4] = 1;  // a token above 3 (renormalised or not)
        family.build(freqs, 7, count);
        expect(r, !family.usable, "a family of %d tables with token 4 is usable", count);
    }
    SmallAlphabet tooMany;
    tooMany.build(randomFrequencies(17, 4, rng), 0, 17);
    expect(r, !tooMany.usable, "a family of 17 tables is usable");
    return r;
}

}  // namespace plx::ptm::detail::PLX_ISA_NS
