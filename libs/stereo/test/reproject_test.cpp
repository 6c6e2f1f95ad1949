#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <plx/core/cpu.h>
#include <plx/raster/raster.h>
#include <plx/scene/generators.h>
#include <plx/stereo/holes.h>
#include <plx/stereo/reproject.h>

namespace plx::stereo {
namespace {

// The second eye's targets plus the hole mask.
struct SecondEye {
    raster::FrameBuffers buffers;
    Image<uint8_t> holeMask;
    explicit SecondEye(int w, int h) {
        buffers.resize(w, h);
        holeMask.resize(w, h);
    }
    SecondEyeTargets targets() {
        return {buffers.color.view(), buffers.depth.view(), buffers.id.view(), holeMask.view()};
    }
};

template <class T>
ImageView<const T> ro(const Image<T>& image) {
    return image.view();
}

FirstEyeTargets firstTargets(const raster::FrameBuffers& b) {
    return {b.color.view(), b.depth.view(), b.id.view()};
}

// office:2 seen from its first viewpoint, first eye of `desc`.
struct OfficeEye {
    scene::Scene scene = *scene::generateOffice(2);
    raster::FrameBuffers first;
    StereoRig rig;
    explicit OfficeEye(StereoRigDesc desc, int w = 160, int h = 120)
        : rig(*StereoRig::create(*scene::cameraAt(scene, scene.viewpoints.front(), w, h), desc)) {
        first.resize(w, h);
        auto renderer = std::move(raster::Renderer::create({2})).value();
        renderer->render(scene, rig.first(), {}, first.targets());
    }
};

TEST(Reproject, ZeroSeparationGivesTheFirstEyeExactly) {
    for (StereoRigType type : {StereoRigType::kConverged, StereoRigType::kParallel}) {
        for (Eye eye : {Eye::kLeft, Eye::kRight}) {
            StereoRigDesc desc;
            desc.type = type;
            desc.separation = 0.0f;
            desc.firstEye = eye;
            OfficeEye o(desc);
            SecondEye second(160, 120);
            ThreadPool pool(2);
            ASSERT_TRUE(
                reproject(firstTargets(o.first), disparityLine(o.rig), second.targets(), &pool)
                    .isOk());
            EXPECT_TRUE(second.buffers.color == o.first.color);
            EXPECT_TRUE(second.buffers.depth == o.first.depth);
            EXPECT_TRUE(second.buffers.id == o.first.id);
            EXPECT_TRUE(second.holeMask == Image<uint8_t>(160, 120, 0));
            auto lut = *OffsetLut::create(disparityLine(o.rig), 20.0f);
            ASSERT_TRUE(reproject(firstTargets(o.first), lut, second.targets()).isOk());
            EXPECT_TRUE(second.buffers.id == o.first.id);
            EXPECT_TRUE(second.holeMask == Image<uint8_t>(160, 120, 0));
        }
    }
}

// The line agrees with the two eye cameras: a world point projected by both lands disparity
// apart, for both rigs and either eye first.
TEST(Reproject, DisparityLineMatchesTheEyeCameras) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (StereoRigType type : {StereoRigType::kConverged, StereoRigType::kParallel}) {
        for (Eye eye : {Eye::kLeft, Eye::kRight}) {
            CameraDesc c;
            c.eyePos = {0.3f, 1.2f, 4.0f};
            c.targetPos = {0.0f, 1.0f, 0.0f};
            c.width = 320;
            c.height = 200;
            StereoRigDesc desc{type, 0.1f, 2.5f, eye};
            auto rig = *StereoRig::create(*Camera::create(c), desc);
            DisparityLine line = disparityLine(rig);
            for (int i = 0; i < 50; ++i) {
                Vec3 p = c.targetPos + Vec3(u(rng), u(rng), 2.0f * u(rng));
                Vec2 a, b;
                ASSERT_TRUE(rig.first().projectToPixel(p, &a));
                ASSERT_TRUE(rig.second().projectToPixel(p, &b));
                float z = -(rig.first().viewFromWorld() * Vec4(p, 1.0f)).z;
                EXPECT_NEAR(b.x - a.x, line.perInvW / z + line.offsetPx, 2e-3f);
                EXPECT_NEAR(b.y, a.y, 2e-3f);
            }
        }
    }
}

// Hand-made targets: a wall of ID `wallId` at 1/w `wallInvW`, with a box of ID `boxId` at
// 1/w `boxInvW` over columns [bx0, bx1) and rows [by0, by1).
raster::FrameBuffers wallWithBox(int w, int h, float wallInvW, float boxInvW, int bx0, int bx1,
                                 int by0, int by1) {
    raster::FrameBuffers b;
    b.resize(w, h);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            bool box = x >= bx0 && x < bx1 && y >= by0 && y < by1;
            b.depth.at(x, y) = box ? boxInvW : wallInvW;
            b.id.at(x, y) = box ? 2u : 1u;
            b.color.at(x, y) = box ? Rgba8{200, 10, 10, 255} : Rgba8{uint8_t(x), 90, 90, 255};
        }
    }
    return b;
}

TEST(Reproject, FrontoParallelPlaneHasNoInteriorHole) {
    // Stripes of several IDs at one depth; a fractional shift of 3.3 px moves it rigidly.
    raster::FrameBuffers first = wallWithBox(64, 8, 0.5f, 0.5f, 10, 30, 0, 8);
    for (float b : {3.3f, -3.3f, 0.49f, -0.51f}) {
        SecondEye second(64, 8);
        ASSERT_TRUE(reproject(firstTargets(first), DisparityLine{-2.0f, b + 1.0f}, second.targets())
                        .isOk());
        int shift = int(std::floor(0.5f + b));
        for (int y = 0; y < 8; ++y) {
            for (int x = 0; x < 64; ++x) {
                int src = x - shift;
                bool inside = src >= 0 && src < 64;
                ASSERT_EQ(second.holeMask.at(x, y), inside ? 0 : 1) << b << " " << x;
                if (inside) {
                    ASSERT_EQ(second.buffers.id.at(x, y), first.id.at(src, y));
                }
            }
        }
    }
}

TEST(Reproject, DepthStepOpensADisocclusionOnThePredictedSide) {
    // Parallel rig with e f = 8 px: the wall (1/w 0.25) moves 2 px, the box (1/w 1) 8 px, so a
    // gap of 6 px opens beside the box, on its right when the left eye comes first (the right
    // eye sees past the box's right side) and on its left otherwise.
    const int w = 100, h = 40;
    raster::FrameBuffers first = wallWithBox(w, h, 0.25f, 1.0f, 40, 60, 10, 30);
    for (Eye eye : {Eye::kLeft, Eye::kRight}) {
        StereoRigDesc desc{StereoRigType::kParallel, 0.08f, 3.0f, eye};
        DisparityLine line = *disparityLine(desc, 100.0f);
        SecondEye second(w, h);
        ASSERT_TRUE(reproject(firstTargets(first), line, second.targets()).isOk());
        HoleScratch scratch;
        HoleSet holes;
        findHoles(ro(second.holeMask), HoleConnectivity::k8, scratch, holes);
        classifyHoles(ro(second.buffers.id), holes);
        // The box gap and the 2-column strip at the border the wall moves away from.
        ASSERT_EQ(holes.holes.size(), 2u);
        int gapX0 = eye == Eye::kLeft ? 52 : 42;
        bool found = false;
        for (const Hole& hole : holes.holes) {
            EXPECT_EQ(hole.holeClass, HoleClass::kDisocclusion);
            if (hole.box.y0 == 10) {
                found = true;
                EXPECT_EQ(hole.box.x0, gapX0);
                EXPECT_EQ(hole.box.x1, gapX0 + 5);
                EXPECT_EQ(hole.box.y1, 29);
                EXPECT_EQ(hole.pixelCount, 6 * 20);
                EXPECT_EQ(hole.segmentCount, 20);
            } else {
                EXPECT_EQ(hole.box.x0, eye == Eye::kLeft ? w - 2 : 0);
                EXPECT_EQ(hole.box.x1 - hole.box.x0, 1);
                EXPECT_EQ(hole.pixelCount, 2 * h);
            }
        }
        EXPECT_TRUE(found);
        // The box covers the wall it moved over: nearer wins.
        int boxX0 = eye == Eye::kLeft ? 32 : 48;
        EXPECT_EQ(second.buffers.id.at(boxX0, 20), 2u);
        EXPECT_EQ(second.buffers.id.at(boxX0 + 19, 20), 2u);
        EXPECT_EQ(second.buffers.id.at(eye == Eye::kLeft ? boxX0 - 1 : boxX0 + 20, 20), 1u);
    }
}

TEST(Reproject, StretchedSlantedPlaneGivesExpansionHoles) {
    // One polygon whose 1/w falls from 1 to 0.2 across the row: with the left eye first and
    // e f = 30 the offset grows by 0.24 px per column, so cracks open every few columns.
    const int w = 100, h = 12;
    raster::FrameBuffers first;
    first.resize(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            first.depth.at(x, y) = 1.0f - 0.8f * float(x) / float(w);
            first.id.at(x, y) = 7;
            first.color.at(x, y) = {uint8_t(2 * x), 50, uint8_t(y), 255};
        }
    SecondEye second(w, h);
    ASSERT_TRUE(
        reproject(firstTargets(first), DisparityLine{-30.0f, 0.0f}, second.targets()).isOk());
    HoleScratch scratch;
    HoleSet holes;
    findHoles(ro(second.holeMask), HoleConnectivity::k8, scratch, holes);
    classifyHoles(ro(second.buffers.id), holes);
    int expansion = 0;
    for (const Hole& hole : holes.holes) {
        bool border = hole.box.x0 == 0 || hole.box.x1 == w - 1;
        EXPECT_EQ(hole.holeClass, border ? HoleClass::kDisocclusion : HoleClass::kExpansion);
        if (hole.holeClass == HoleClass::kExpansion) {
            ++expansion;
            EXPECT_EQ(hole.polygonId, 7u);
            EXPECT_EQ(hole.box.y0, 0);
            EXPECT_EQ(hole.box.y1, h - 1);
        }
    }
    EXPECT_GT(expansion, 10);
    fillExpansionHoles(holes, second.targets());
    for (const Hole& hole : holes.holes) {
        for (int s = hole.firstSegment; s < hole.firstSegment + hole.segmentCount; ++s) {
            const HoleSegment& seg = holes.segments[size_t(s)];
            for (int x = seg.xStart; x <= seg.xEnd; ++x) {
                bool filled = hole.holeClass == HoleClass::kExpansion;
                EXPECT_EQ(second.holeMask.at(x, seg.y), filled ? 0 : 1);
                if (!filled) continue;
                EXPECT_EQ(second.buffers.id.at(x, seg.y), 7u);
                float d = second.buffers.depth.at(x, seg.y);
                EXPECT_LT(d, second.buffers.depth.at(seg.xStart - 1, seg.y));
                EXPECT_GT(d, second.buffers.depth.at(seg.xEnd + 1, seg.y));
                uint8_t r = second.buffers.color.at(x, seg.y).r;
                EXPECT_GE(r, second.buffers.color.at(seg.xStart - 1, seg.y).r);
                EXPECT_LE(r, second.buffers.color.at(seg.xEnd + 1, seg.y).r);
            }
        }
    }
}

TEST(Reproject, LutAgreesWithTheDirectFormWithinItsBound) {
    DisparityLine line = *disparityLine(StereoRigDesc{}, 623.5f);
    for (int entries : {2, 256, 4096, 65536}) {
        auto lut = *OffsetLut::create(line, 20.0f, entries);
        EXPECT_FLOAT_EQ(lut.maxErrorPx(),
                        std::fabs(line.perInvW) * 20.0f / (2.0f * float(entries - 1)));
        std::mt19937 rng(entries);
        std::uniform_real_distribution<float> u(0.0f, 20.0f);
        for (int i = 0; i < 10000; ++i) {
            float invW = i == 0 ? 0.0f : i == 1 ? 20.0f : u(rng);
            float direct = line.perInvW * invW + line.offsetPx;
            ASSERT_NEAR(lut.centredOffset(invW) - 0.5f, direct, lut.maxErrorPx() * 1.001f + 1e-4f);
        }
        // Nearer than the table's range: clamped to its last entry.
        EXPECT_EQ(lut.centredOffset(50.0f), lut.centredOffset(20.0f));
    }
    // On a rendered eye every pixel lands in the column the direct form gives, or one beside it
    // where the landing position is within the bound of a column boundary.
    StereoRigDesc desc;
    desc.separation = 0.3f;
    OfficeEye o(desc);
    DisparityLine officeLine = disparityLine(o.rig);
    auto lut = *OffsetLut::create(officeLine, 1.0f / 0.05f, 4096);
    for (int y = 0; y < 120; ++y)
        for (int x = 0; x < 160; ++x) {
            float invW = o.first.depth.at(x, y);
            float direct = float(x) + officeLine.perInvW * invW + officeLine.offsetPx + 0.5f;
            float viaLut = float(x) + lut.centredOffset(invW);
            if (std::floor(direct) != std::floor(viaLut)) {
                EXPECT_LT(std::fabs(direct - std::round(direct)), lut.maxErrorPx() + 1e-4f);
            }
        }
}

TEST(Reproject, ParallelRowsEqualOneThread) {
    StereoRigDesc desc;
    desc.separation = 0.2f;
    for (Eye eye : {Eye::kLeft, Eye::kRight}) {
        desc.firstEye = eye;
        OfficeEye o(desc, 200, 150);
        SecondEye one(200, 150), many(200, 150);
        ThreadPool pool(2);
        DisparityLine line = disparityLine(o.rig);
        ASSERT_TRUE(reproject(firstTargets(o.first), line, one.targets()).isOk());
        ASSERT_TRUE(reproject(firstTargets(o.first), line, many.targets(), &pool).isOk());
        EXPECT_TRUE(one.buffers.color == many.buffers.color);
        EXPECT_TRUE(one.buffers.depth == many.buffers.depth);
        EXPECT_TRUE(one.buffers.id == many.buffers.id);
        EXPECT_TRUE(one.holeMask == many.holeMask);
        auto lut = *OffsetLut::create(line, 20.0f);
        ASSERT_TRUE(reproject(firstTargets(o.first), lut, one.targets()).isOk());
        ASSERT_TRUE(reproject(firstTargets(o.first), lut, many.targets(), &pool).isOk());
        EXPECT_TRUE(one.buffers.id == many.buffers.id);
        EXPECT_TRUE(one.holeMask == many.holeMask);
        // A real separation opens holes, all found and classified.
        HoleScratch scratch;
        HoleSet holes;
        findHoles(ro(one.holeMask), HoleConnectivity::k8, scratch, holes);
        classifyHoles(ro(one.buffers.id), holes);
        int64_t maskPixels = 0;
        for (uint8_t m : std::vector<uint8_t>(one.holeMask.data(),
                                              one.holeMask.data() + one.holeMask.pixelCount()))
            maskPixels += m;
        EXPECT_GT(maskPixels, 0);
        EXPECT_EQ(holes.pixelCount, maskPixels);
    }
}

// Fu section 2 as written, pixel by pixel: clear the second eye to holes, move each first-eye
// pixel to floor(x + 0.5 + offset), and keep it where the target is a hole or lies farther. Then
// the gaps closed (detail::RowGap): between the landings of neighbouring columns two or more
// pixels apart in their order, a pixel whose landing lies farther than the nearer of them becomes
// a hole; where they are three or more apart, so does one beyond an end, as far again less one,
// whose landing lies farther than that end by more than twice the two columns' difference.
// `centredOffset` gives a pixel's offset plus the pixel centre's 0.5 from its 1/w: the direct
// form's or the table's (OffsetLut::centredOffset).
void reprojectByTheBook(const raster::FrameBuffers& first,
                        const std::function<float(float)>& centredOffset, SecondEye* second) {
    const int w = first.color.width(), h = first.color.height();
    auto landing = [&](int x, int y) {
        float pos = float(x) + centredOffset(first.depth.at(x, y));
        return pos >= 0.0f && pos < float(w) ? int(pos) : -1;
    };
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            second->buffers.color.at(x, y) = Rgba8{};
            second->buffers.depth.at(x, y) = 0.0f;
            second->buffers.id.at(x, y) = 0;
            second->holeMask.at(x, y) = 1;
        }
        for (int x = 0; x < w; ++x) {
            float invW = first.depth.at(x, y);
            float pos = float(x) + centredOffset(invW);
            if (!(pos >= 0.0f && pos < float(w))) continue;
            int tx = int(pos);
            if (second->holeMask.at(tx, y) || invW > second->buffers.depth.at(tx, y)) {
                second->buffers.color.at(tx, y) = first.color.at(x, y);
                second->buffers.depth.at(tx, y) = invW;
                second->buffers.id.at(tx, y) = first.id.at(x, y);
                second->holeMask.at(tx, y) = 0;
            }
        }
        auto takeOffFarther = [&](int begin, int end, float limit) {
            for (int t = std::max(begin, 0); t < std::min(end, w); ++t) {
                if (second->holeMask.at(t, y) || !(second->buffers.depth.at(t, y) < limit))
                    continue;
                second->buffers.color.at(t, y) = Rgba8{};
                second->buffers.depth.at(t, y) = 0.0f;
                second->buffers.id.at(t, y) = 0;
                second->holeMask.at(t, y) = 1;
            }
        };
        for (int x = 0; x + 1 < w; ++x) {
            const int tA = landing(x, y), tB = landing(x + 1, y);
            if (tA < 0 || tB < 0 || tB - tA < 2) continue;
            const float depthA = first.depth.at(x, y), depthB = first.depth.at(x + 1, y);
            takeOffFarther(tA + 1, tB, std::max(depthA, depthB));
            if (tB - tA < 3) continue;
            const float margin = 2.0f * std::fabs(depthA - depthB);
            takeOffFarther(tA - (tB - tA) + 1, tA, depthA - margin);
            takeOffFarther(tB + 1, tB + (tB - tA), depthB - margin);
        }
    }
}

void reprojectByTheBook(const raster::FrameBuffers& first, const DisparityLine& line,
                        SecondEye* second) {
    reprojectByTheBook(
        first, [line](float invW) { return line.perInvW * invW + (line.offsetPx + 0.5f); }, second);
}

// A first eye of random 1/w from 13 levels (0 is the background), colours and IDs.
raster::FrameBuffers randomFirstEye(int w, int h, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> level(0, 12);
    std::uniform_int_distribution<uint32_t> any;
    raster::FrameBuffers first;
    first.resize(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            first.depth.at(x, y) = float(level(rng)) * 0.25f;
            uint32_t c = any(rng);
            first.color.at(x, y) = Rgba8{uint8_t(c), uint8_t(c >> 8), uint8_t(c >> 16), 255};
            first.id.at(x, y) = 1 + (any(rng) % 1000);
        }
    return first;
}

// Colour, depth, ID and hole mask all equal.
void expectSameSecondEye(const SecondEye& got, const SecondEye& expected,
                         const DisparityLine& line) {
    EXPECT_TRUE(got.buffers.color == expected.buffers.color) << line.perInvW;
    EXPECT_TRUE(got.buffers.depth == expected.buffers.depth) << line.perInvW;
    EXPECT_TRUE(got.buffers.id == expected.buffers.id) << line.perInvW;
    EXPECT_TRUE(got.holeMask == expected.holeMask) << line.perInvW;
}

// Disparity ranges wider than a random first eye of width ~100, so that rows have collisions,
// gaps and landings outside on both sides.
const DisparityLine kWideLines[] = {{-40.0f, 12.0f}, {55.0f, -30.0f}, {-3.0f, 0.7f}};

// On every row-kernel path this process can run (row_pass.inl: scalar with SSE2, AVX2).
TEST(Reproject, RowPassEqualsThePaperOnRandomDepths) {
    const int w = 97, h = 23;
    const raster::FrameBuffers first = randomFirstEye(w, h, 7);
    ActiveIsaGuard restore;
    for (Isa isa : runnableIsas())
        for (DisparityLine line : kWideLines) {
            SCOPED_TRACE(std::string(isaName(isa)));
            ASSERT_TRUE(setActiveIsa(isa).isOk());
            SecondEye expected(w, h), got(w, h);
            reprojectByTheBook(first, line, &expected);
            ThreadPool pool(2);
            ASSERT_TRUE(reproject(firstTargets(first), line, got.targets(), &pool).isOk());
            expectSameSecondEye(got, expected, line);

            // A second eye shown as colour only: colour and mask everywhere, depth and ID where the
            // hole search reads them (hole pixels and their row neighbours), the rest untouched;
            // in its own planes, or in the first eye's (read beside each run before it is marked).
            for (bool shared : {false, true}) {
                SCOPED_TRACE(shared ? "planes shared" : "planes apart");
                raster::FrameBuffers source = first;
                SecondEye lean(w, h);
                lean.buffers.depth.view().fill(-7.0f);
                lean.buffers.id.view().fill(0xdeadu);
                SecondEyeTargets leanTargets = lean.targets();
                leanTargets.depthAndIds = false;
                if (shared) {
                    leanTargets.depth = source.depth.view();
                    leanTargets.id = source.id.view();
                }
                ASSERT_TRUE(reproject(firstTargets(source), line, leanTargets, &pool).isOk());
                EXPECT_TRUE(lean.buffers.color == expected.buffers.color) << line.perInvW;
                EXPECT_TRUE(lean.holeMask == expected.holeMask) << line.perInvW;
                int holes = 0, untouched = 0;
                for (int y = 0; y < h; ++y)
                    for (int x = 0; x < w; ++x) {
                        auto isHole = [&](int c) {
                            return c >= 0 && c < w && expected.holeMask.at(c, y);
                        };
                        const float depth = leanTargets.depth.at(x, y);
                        const uint32_t id = leanTargets.id.at(x, y);
                        if (isHole(x)) {
                            ++holes;
                            EXPECT_EQ(depth, 0.0f);
                            EXPECT_EQ(id, 0u);
                        } else if (isHole(x - 1) || isHole(x + 1)) {
                            EXPECT_EQ(id, expected.buffers.id.at(x, y));
                            EXPECT_EQ(depth, expected.buffers.depth.at(x, y));
                        } else {
                            untouched += id == (shared ? first.id.at(x, y) : 0xdeadu);
                        }
                    }
                EXPECT_GT(holes, 0);
                EXPECT_GT(untouched, 0);
            }
        }
}

// A first eye of slanted surfaces: each row in runs of 1/w linear along the row (random
// lengths, levels and slopes), as rendered planes give, so that most pixels land one column
// after their left neighbour and the rest open gaps or collide at the runs' ends.
raster::FrameBuffers slantedFirstEye(int w, int h, unsigned seed) {
    raster::FrameBuffers first = randomFirstEye(w, h, seed);
    std::mt19937 rng(seed + 1);
    std::uniform_int_distribution<int> runLength(1, 40);
    std::uniform_real_distribution<float> level(0.0f, 2.0f), slope(-0.02f, 0.02f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w;) {
            const int end = std::min(w, x + runLength(rng));
            const float start = level(rng), step = slope(rng);
            for (int k = x; k < end; ++k) first.depth.at(k, y) = start + step * float(k - x);
            x = end;
        }
    return first;
}

TEST(Reproject, RowPassEqualsThePaperOnSlantedRuns) {
    const int w = 301, h = 17;
    const raster::FrameBuffers first = slantedFirstEye(w, h, 11);
    ActiveIsaGuard restore;
    for (Isa isa : runnableIsas())
        for (DisparityLine line : {DisparityLine{-6.0f, 2.5f}, DisparityLine{7.0f, -4.0f}}) {
            SCOPED_TRACE(std::string(isaName(isa)));
            ASSERT_TRUE(setActiveIsa(isa).isOk());
            SecondEye expected(w, h), got(w, h);
            reprojectByTheBook(first, line, &expected);
            ASSERT_TRUE(reproject(firstTargets(first), line, got.targets()).isOk());
            EXPECT_TRUE(got.buffers.color == expected.buffers.color) << line.perInvW;
            EXPECT_TRUE(got.buffers.id == expected.buffers.id) << line.perInvW;
            EXPECT_TRUE(got.holeMask == expected.holeMask) << line.perInvW;
        }
}

// The offset table's row pass (Fu section 2) on every kernel path, against the paper's pixel
// loop with the table's offsets: random levels and slanted runs (1/w up to 3), a table of 4096
// entries over [0, 2], and one of 17 over [0, 1], whose coarse steps make neighbours collide and
// whose last entry takes two thirds of the levels.
TEST(Reproject, TableRowPassEqualsThePaper) {
    const raster::FrameBuffers firsts[] = {randomFirstEye(97, 23, 5), slantedFirstEye(301, 17, 13)};
    ActiveIsaGuard restore;
    for (Isa isa : runnableIsas())
        for (const raster::FrameBuffers& first : firsts)
            for (DisparityLine line : kWideLines)
                for (auto [maxInvW, entries] : {std::pair{2.0f, 4096}, std::pair{1.0f, 17}}) {
                    SCOPED_TRACE(std::string(isaName(isa)) + " entries " + std::to_string(entries));
                    ASSERT_TRUE(setActiveIsa(isa).isOk());
                    const int w = first.color.width(), h = first.color.height();
                    const OffsetLut lut = *OffsetLut::create(line, maxInvW, entries);
                    SecondEye expected(w, h), got(w, h);
                    reprojectByTheBook(
                        first, [&lut](float invW) { return lut.centredOffset(invW); }, &expected);
                    ThreadPool pool(2);
                    ASSERT_TRUE(reproject(firstTargets(first), lut, got.targets(), &pool).isOk());
                    expectSameSecondEye(got, expected, line);
                }
}

TEST(Reproject, BadParametersAreRejected) {
    StereoRigDesc nan;
    nan.separation = std::nanf("");
    EXPECT_FALSE(disparityLine(nan, 600.0f).isOk());
    StereoRigDesc negative;
    negative.separation = -0.1f;
    EXPECT_FALSE(disparityLine(negative, 600.0f).isOk());
    StereoRigDesc noConvergence;
    noConvergence.convergence = 0.0f;
    EXPECT_FALSE(disparityLine(noConvergence, 600.0f).isOk());
    EXPECT_FALSE(disparityLine(StereoRigDesc{}, std::nanf("")).isOk());
    EXPECT_FALSE(disparityLine(StereoRigDesc{}, 0.0f).isOk());
    EXPECT_FALSE(OffsetLut::create({}, 0.0f).isOk());
    EXPECT_FALSE(OffsetLut::create({}, 20.0f, 1).isOk());
    EXPECT_FALSE(OffsetLut::create({std::nanf(""), 0.0f}, 20.0f).isOk());

    raster::FrameBuffers first;
    first.resize(16, 8);
    SecondEye ok(16, 8), wide(17, 8), tall(16, 9);
    EXPECT_TRUE(reproject(firstTargets(first), DisparityLine{}, ok.targets()).isOk());
    EXPECT_FALSE(reproject(firstTargets(first), DisparityLine{}, wide.targets()).isOk());
    EXPECT_FALSE(reproject(firstTargets(first), DisparityLine{}, tall.targets()).isOk());
    SecondEyeTargets maskOff = ok.targets();
    maskOff.holeMask = tall.holeMask.view();
    EXPECT_FALSE(reproject(firstTargets(first), DisparityLine{}, maskOff).isOk());
    EXPECT_FALSE(
        reproject(firstTargets(first), DisparityLine{0.0f, std::nanf("")}, ok.targets()).isOk());
    // The second eye's planes: the first eye's own only without depthAndIds, never partly.
    SecondEyeTargets shared = ok.targets();
    shared.depth = first.depth.view();
    shared.id = first.id.view();
    EXPECT_FALSE(reproject(firstTargets(first), DisparityLine{}, shared).isOk());
    shared.depthAndIds = false;
    EXPECT_TRUE(reproject(firstTargets(first), DisparityLine{}, shared).isOk());
    SecondEyeTargets crossed = shared;
    crossed.depth = {reinterpret_cast<float*>(first.id.data()), 16, 8, 16};
    crossed.id = {reinterpret_cast<uint32_t*>(first.depth.data()), 16, 8, 16};
    Status overlapping = reproject(firstTargets(first), DisparityLine{}, crossed);
    EXPECT_FALSE(overlapping.isOk());
    EXPECT_NE(overlapping.message().find("overlap"), std::string::npos) << overlapping.message();
    SecondEyeTargets halfShared = shared;
    halfShared.id = ok.buffers.id.view();
    EXPECT_FALSE(reproject(firstTargets(first), DisparityLine{}, halfShared).isOk());

    raster::FrameBuffers empty;
    SecondEye none(0, 0);
    EXPECT_FALSE(reproject(firstTargets(empty), DisparityLine{}, none.targets()).isOk());

    // Views claiming 50000x50000 pixels over one pixel each: refused on their size (the row
    // pass's landing tags), before any pixel is read.
    Rgba8 color{};
    float depth = 0.0f;
    uint32_t id = 0;
    uint8_t hole = 0;
    const int huge = 50000;
    const FirstEyeTargets hugeFirst{
        {&color, huge, huge, 0}, {&depth, huge, huge, 0}, {&id, huge, huge, 0}};
    const SecondEyeTargets hugeSecond{{&color, huge, huge, 0},
                                      {&depth, huge, huge, 0},
                                      {&id, huge, huge, 0},
                                      {&hole, huge, huge, 0}};
    Status tooLarge = reproject(hugeFirst, DisparityLine{}, hugeSecond);
    EXPECT_FALSE(tooLarge.isOk());
    EXPECT_NE(tooLarge.message().find("too large"), std::string::npos) << tooLarge.message();
}

// Hand-made masks: '#' is a hole pixel.
Image<uint8_t> mask(const std::vector<std::string>& rows) {
    Image<uint8_t> m(int(rows[0].size()), int(rows.size()));
    for (int y = 0; y < m.height(); ++y)
        for (int x = 0; x < m.width(); ++x) m.at(x, y) = rows[size_t(y)][size_t(x)] == '#';
    return m;
}

HoleSet holesOf(const Image<uint8_t>& m, HoleConnectivity c = HoleConnectivity::k8) {
    HoleScratch scratch;
    HoleSet out;
    findHoles(ro(m), c, scratch, out);
    return out;
}

// Structural invariants: segments contiguous per hole, chained by next, in scan order, counts
// and boxes consistent.
void expectConsistent(const HoleSet& set) {
    int64_t pixels = 0;
    for (const Hole& h : set.holes) {
        int count = 0;
        PixelBox box{1 << 30, 1 << 30, -1, -1};
        for (int s = h.firstSegment; s < h.firstSegment + h.segmentCount; ++s) {
            const HoleSegment& seg = set.segments[size_t(s)];
            EXPECT_EQ(seg.count, seg.xEnd - seg.xStart + 1);
            EXPECT_EQ(seg.next, s + 1 < h.firstSegment + h.segmentCount ? s + 1 : -1);
            if (s > h.firstSegment) {
                const HoleSegment& prev = set.segments[size_t(s - 1)];
                EXPECT_TRUE(prev.y < seg.y || (prev.y == seg.y && prev.xEnd < seg.xStart));
            }
            count += seg.count;
            box = {std::min(box.x0, seg.xStart), std::min(box.y0, seg.y),
                   std::max(box.x1, seg.xEnd), std::max(box.y1, seg.y)};
        }
        EXPECT_EQ(count, h.pixelCount);
        EXPECT_EQ(box.x0, h.box.x0);
        EXPECT_EQ(box.y0, h.box.y0);
        EXPECT_EQ(box.x1, h.box.x1);
        EXPECT_EQ(box.y1, h.box.y1);
        pixels += count;
    }
    EXPECT_EQ(pixels, set.pixelCount);
}

// Masks laid out as images.
// clang-format off
TEST(Holes, UShapeIsOneHole) {
    HoleSet set = holesOf(mask({"#...#",
                                "#...#",
                                "#####"}));
    expectConsistent(set);
    ASSERT_EQ(set.holes.size(), 1u);
    EXPECT_EQ(set.holes[0].segmentCount, 5);
    EXPECT_EQ(set.holes[0].pixelCount, 9);
    // Upside down: one hole that splits into two arms.
    set = holesOf(mask({"#####",
                        "#...#",
                        "#...#"}));
    expectConsistent(set);
    ASSERT_EQ(set.holes.size(), 1u);
}

TEST(Holes, DiagonalChainsDependOnConnectivity) {
    Image<uint8_t> m = mask({"#...",
                             ".#..",
                             "..#.",
                             "...#"});
    EXPECT_EQ(holesOf(m, HoleConnectivity::k8).holes.size(), 1u);
    EXPECT_EQ(holesOf(m, HoleConnectivity::k4).holes.size(), 4u);
    Image<uint8_t> anti = mask({"...#",
                                "..#.",
                                ".#..",
                                "#..."});
    EXPECT_EQ(holesOf(anti, HoleConnectivity::k8).holes.size(), 1u);
    EXPECT_EQ(holesOf(anti, HoleConnectivity::k4).holes.size(), 4u);
    // One column apart is never touching.
    EXPECT_EQ(holesOf(mask({"#..", "..#"}), HoleConnectivity::k8).holes.size(), 2u);
}

TEST(Holes, TwoHolesMergeLaterDownTheImage) {
    // Three arms meeting at different rows; the holes are numbered by their first pixel.
    HoleSet set = holesOf(mask({"#..#..#.....#",
                                "#..#..#.....#",
                                "#..####.....#",
                                "#.....#......",
                                "#######......"}));
    expectConsistent(set);
    ASSERT_EQ(set.holes.size(), 2u);
    EXPECT_EQ(set.holes[0].box.x1, 6);
    EXPECT_EQ(set.holes[0].box.y1, 4);
    EXPECT_EQ(set.holes[1].box.x0, 12);
    EXPECT_EQ(set.holes[1].pixelCount, 3);
}

TEST(Holes, SinglePixelsAndFullRows) {
    HoleSet set = holesOf(mask({"#.#.#",
                                ".....",
                                "#####",
                                "#####",
                                ".....",
                                "....#"}));
    expectConsistent(set);
    ASSERT_EQ(set.holes.size(), 5u);
    EXPECT_EQ(set.holes[3].pixelCount, 10);
    EXPECT_EQ(set.holes[3].segmentCount, 2);
    EXPECT_EQ(set.holes[4].pixelCount, 1);
    EXPECT_EQ(set.holes[4].box.y0, 5);
    EXPECT_TRUE(holesOf(mask({"....", "...."})).holes.empty());
    HoleSet all = holesOf(mask({"####", "####"}));
    ASSERT_EQ(all.holes.size(), 1u);
    EXPECT_EQ(all.pixelCount, 8);
}

// clang-format on

// Every pixel's hole equals a flood fill's component, on random masks of growing density, for
// both connectivities; the scratch and output are reused across masks.
TEST(Holes, MatchFloodFillOnRandomMasks) {
    std::mt19937 rng(11);
    HoleScratch scratch;
    HoleSet set;
    for (int trial = 0; trial < 60; ++trial) {
        int w = 1 + int(rng() % 40), h = 1 + int(rng() % 30);
        float density = float(trial % 6) / 6.0f + 0.05f;
        Image<uint8_t> m(w, h);
        std::bernoulli_distribution hole(density);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) m.at(x, y) = hole(rng);
        for (HoleConnectivity c : {HoleConnectivity::k4, HoleConnectivity::k8}) {
            findHoles(ro(m), c, scratch, set);
            expectConsistent(set);
            Image<int> mine(w, h, -1);
            for (size_t i = 0; i < set.holes.size(); ++i)
                for (int s = set.holes[i].firstSegment;
                     s < set.holes[i].firstSegment + set.holes[i].segmentCount; ++s)
                    for (int x = set.segments[size_t(s)].xStart; x <= set.segments[size_t(s)].xEnd;
                         ++x)
                        mine.at(x, set.segments[size_t(s)].y) = int(i);
            // Flood fill in scan order numbers components as findHoles numbers holes.
            Image<int> ref(w, h, -1);
            int components = 0;
            std::vector<std::pair<int, int>> stack;
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    if (!m.at(x, y) || ref.at(x, y) >= 0) continue;
                    stack = {{x, y}};
                    ref.at(x, y) = components;
                    while (!stack.empty()) {
                        auto [px, py] = stack.back();
                        stack.pop_back();
                        for (int dy = -1; dy <= 1; ++dy)
                            for (int dx = -1; dx <= 1; ++dx) {
                                if (c == HoleConnectivity::k4 && dx != 0 && dy != 0) continue;
                                int nx = px + dx, ny = py + dy;
                                if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
                                if (!m.at(nx, ny) || ref.at(nx, ny) >= 0) continue;
                                ref.at(nx, ny) = components;
                                stack.push_back({nx, ny});
                            }
                    }
                    ++components;
                }
            ASSERT_EQ(int(set.holes.size()), components);
            ASSERT_TRUE(mine == ref) << "trial " << trial;
        }
    }
}

void expectSameHoles(const HoleSet& a, const HoleSet& b) {
    ASSERT_EQ(a.pixelCount, b.pixelCount);
    ASSERT_EQ(a.segments.size(), b.segments.size());
    ASSERT_EQ(a.holes.size(), b.holes.size());
    for (size_t s = 0; s < a.segments.size(); ++s) {
        const HoleSegment &p = a.segments[s], &q = b.segments[s];
        EXPECT_TRUE(p.xStart == q.xStart && p.xEnd == q.xEnd && p.count == q.count && p.y == q.y &&
                    p.next == q.next)
            << "segment " << s;
    }
    for (size_t h = 0; h < a.holes.size(); ++h) {
        const Hole &p = a.holes[h], &q = b.holes[h];
        EXPECT_TRUE(p.firstSegment == q.firstSegment && p.segmentCount == q.segmentCount &&
                    p.pixelCount == q.pixelCount && p.box.x0 == q.box.x0 && p.box.y0 == q.box.y0 &&
                    p.box.x1 == q.box.x1 && p.box.y1 == q.box.y1 && p.holeClass == q.holeClass &&
                    p.polygonId == q.polygonId && p.polygonCount == q.polygonCount)
            << "hole " << h;
    }
}

TEST(Holes, RowPassRunsGiveTheMasksHoles) {
    // The runs the row pass lists (one thread or two, planes written or not) merge into the holes
    // found on its mask, and classifying them on two threads gives the classes of one thread.
    // Without a mask the row pass lists the same runs and writes the same pixels.
    ThreadPool pool(2);
    auto check = [&](const raster::FrameBuffers& first, const DisparityLine& line, int w, int h) {
        for (bool planes : {true, false}) {
            for (ThreadPool* threads : {static_cast<ThreadPool*>(nullptr), &pool}) {
                SecondEye second(w, h);
                HoleRuns runs;
                runs.rows.assign(size_t(h) + 3, {HoleRun{1, 2}});  // stale rows are replaced
                SecondEyeTargets targets = second.targets();
                targets.depthAndIds = planes;
                targets.holeRuns = &runs;
                ASSERT_TRUE(reproject(firstTargets(first), line, targets, threads).isOk());
                ASSERT_EQ(runs.rows.size(), size_t(h));
                HoleScratch scratch;
                HoleSet fromMask, fromRuns;
                findHoles(ro(second.holeMask), HoleConnectivity::k8, scratch, fromMask);
                findHoles(runs, HoleConnectivity::k8, scratch, fromRuns);
                EXPECT_GT(fromRuns.pixelCount, 0);
                classifyHoles(ro(second.buffers.id), fromMask);
                classifyHoles(ro(second.buffers.id), fromRuns, {}, &pool);
                expectSameHoles(fromMask, fromRuns);

                SecondEye bare(w, h);
                std::fill_n(bare.holeMask.data(), bare.holeMask.pixelCount(), uint8_t(7));
                HoleRuns bareRuns;
                SecondEyeTargets noMask = bare.targets();
                noMask.holeMask = {};
                noMask.depthAndIds = planes;
                noMask.holeRuns = &bareRuns;
                ASSERT_TRUE(reproject(firstTargets(first), line, noMask, threads).isOk());
                HoleSet fromBareRuns;
                findHoles(bareRuns, HoleConnectivity::k8, scratch, fromBareRuns);
                classifyHoles(ro(bare.buffers.id), fromBareRuns);
                expectSameHoles(fromMask, fromBareRuns);
                EXPECT_TRUE(bare.buffers.color == second.buffers.color);
                EXPECT_TRUE(bare.buffers.depth == second.buffers.depth);
                EXPECT_TRUE(bare.buffers.id == second.buffers.id);
                EXPECT_TRUE(std::all_of(bare.holeMask.data(),
                                        bare.holeMask.data() + bare.holeMask.pixelCount(),
                                        [](uint8_t b) { return b == 7; }));
            }
        }
    };
    for (DisparityLine line : kWideLines) check(randomFirstEye(97, 23, 5), line, 97, 23);
    for (Eye eye : {Eye::kLeft, Eye::kRight}) {
        StereoRigDesc desc;
        desc.separation = 0.2f;
        desc.firstEye = eye;
        OfficeEye o(desc, 200, 150);
        check(o.first, disparityLine(o.rig), 200, 150);
    }
}

TEST(Holes, ClassesFollowTheRowNeighboursIds) {
    // Row neighbours: 5|hole|5 -> expansion; 5|hole|6 -> disocclusion; 0 beside -> disocclusion;
    // touching the left border -> disocclusion.
    Image<uint8_t> m = mask({
        ".##...##...#....##.",
        ".#.....#...#.......",
        "...................",
        "#..................",
    });
    Image<uint32_t> ids(19, 4, 5);
    ids.at(8, 0) = 6;  // right of the second hole's first segment
    ids.at(12, 0) = 0;
    ids.at(12, 1) = 0;
    HoleSet set = holesOf(m);
    classifyHoles(ro(ids), set);
    ASSERT_EQ(set.holes.size(), 5u);
    EXPECT_EQ(set.holes[0].holeClass, HoleClass::kExpansion);
    EXPECT_EQ(set.holes[0].polygonId, 5u);
    EXPECT_EQ(set.holes[1].holeClass, HoleClass::kDisocclusion);
    EXPECT_EQ(set.holes[2].holeClass, HoleClass::kDisocclusion);
    EXPECT_EQ(set.holes[2].polygonId, 0u);
    EXPECT_EQ(set.holes[3].holeClass, HoleClass::kExpansion);
    EXPECT_EQ(set.holes[4].holeClass, HoleClass::kDisocclusion);  // x = 0
    EXPECT_EQ(set.holes[0].polygonCount, 1);
    EXPECT_EQ(set.holes[1].polygonCount, 0);
}

TEST(Holes, TrianglesOfOneSurfaceJoinACrack) {
    // One crack, rows bordered by IDs 5|6, 6|7, 7|9: an expansion of 5, 6, 7 and 9 when the
    // predicate chains them (6 with 5, 7 with 6, 9 with 7), else a disocclusion.
    Image<uint8_t> m = mask({
        "...#...",
        "...#...",
        "...#...",
    });
    Image<uint32_t> ids(7, 3, 1);
    uint32_t left[3] = {5, 6, 7}, right[3] = {6, 7, 9};
    for (int y = 0; y < 3; ++y) {
        ids.at(2, y) = left[y];
        ids.at(4, y) = right[y];
    }
    auto chained = [](uint32_t a, uint32_t b) { return a + 1 == b || (a == 7 && b == 9); };
    HoleSet joined = holesOf(m);
    classifyHoles(ro(ids), joined, chained);
    ASSERT_EQ(joined.holes.size(), 1u);
    EXPECT_EQ(joined.holes[0].holeClass, HoleClass::kExpansion);
    EXPECT_EQ(joined.holes[0].polygonId, 5u);
    EXPECT_EQ(joined.holes[0].polygonCount, 4);
    HoleSet paper = holesOf(m);
    classifyHoles(ro(ids), paper);
    EXPECT_EQ(paper.holes[0].holeClass, HoleClass::kDisocclusion);
    HoleSet broken = holesOf(m);
    classifyHoles(ro(ids), broken, [](uint32_t a, uint32_t b) { return a + 1 == b; });
    EXPECT_EQ(broken.holes[0].holeClass, HoleClass::kDisocclusion);  // 9 joins nothing
    // More distinct IDs than kMaxSurfacePolygons: a disocclusion even if all are joined.
    std::vector<std::string> rows(kMaxSurfacePolygons, "..#..");
    Image<uint8_t> tall = mask(rows);
    Image<uint32_t> many(5, kMaxSurfacePolygons, 1);
    for (int y = 0; y < kMaxSurfacePolygons; ++y) {
        many.at(1, y) = uint32_t(10 + y);
        many.at(3, y) = uint32_t(11 + y);
    }
    HoleSet capped = holesOf(tall);
    classifyHoles(ro(many), capped, [](uint32_t, uint32_t) { return true; });
    EXPECT_EQ(capped.holes[0].holeClass, HoleClass::kDisocclusion);
}

}  // namespace
}  // namespace plx::stereo
