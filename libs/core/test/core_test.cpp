#include <atomic>
#include <chrono>
#include <filesystem>
#include <random>
#include <thread>

#include <sys/resource.h>

#include <gtest/gtest.h>
#include <oneapi/tbb/info.h>

#include <plx/core/core.h>
#include <plx/core/memory.h>

namespace plx {
namespace {

TEST(Status, ResultCarriesValueOrError) {
    Result<int> good = 7;
    ASSERT_TRUE(good.isOk());
    EXPECT_EQ(*good, 7);
    Result<int> bad = errorStatus(ErrorCode::kNotFound, "missing thing");
    ASSERT_FALSE(bad.isOk());
    EXPECT_EQ(bad.status().toString(), "not found: missing thing");
}

TEST(Status, MessagesAreOneLineAndQuotedTextPrintable) {
    // A failed status keeps its message to one line whatever it quotes.
    const Status s = errorStatus(ErrorCode::kCorruptData, "unknown type 'a\nb\r\tc\x7f'");
    EXPECT_EQ(s.message(), "unknown type 'a?b??c?'");
    EXPECT_EQ(oneLine("x\ny"), "x?y");
    EXPECT_EQ(oneLine("caf\xc3\xa9"), "caf\xc3\xa9");  // UTF-8 is not a control character
    // A megabyte quoted back keeps its two ends, whole UTF-8 characters, and says what it left out.
    EXPECT_EQ(oneLine(std::string(kMaxMessageChars, 'a')), std::string(kMaxMessageChars, 'a'));
    std::string huge = "'" + std::string(1 << 20, 'x') + "' is not a number";
    const std::string cut = oneLine(huge);
    EXPECT_LE(cut.size(), kMaxMessageChars + 40);
    EXPECT_EQ(cut.substr(0, 3), "'xx");
    EXPECT_EQ(cut.substr(cut.size() - 18), "x' is not a number");
    EXPECT_NE(cut.find("bytes left out"), std::string::npos);
    std::string accents;
    while (accents.size() < 2 * kMaxMessageChars) accents += "\xc3\xa9";
    const std::string cutAccents = oneLine("x" + accents);
    const size_t mark = cutAccents.find(" [... ");
    ASSERT_NE(mark, std::string::npos);
    EXPECT_EQ(mark % 2, 1u);  // "x" and whole two-byte characters before the mark
    EXPECT_EQ((cutAccents.size() - cutAccents.find("...] ") - 5) % 2, 0u);
    EXPECT_EQ(oneLine(std::string(kMaxMessageChars + 1, '\n')).find('\n'), std::string::npos);
    // printable: ASCII only, cut at maxChars with "...".
    EXPECT_EQ(printable("caf\xc3\xa9\n"), "caf???");
    EXPECT_EQ(printable(std::string(200, 'a'), 4), "aaaa...");
    EXPECT_EQ(printable("abcd", 4), "abcd");
}

TEST(Camera, ProjectsTargetToImageCentre) {
    CameraDesc d;
    d.eyePos = {1, 2, 3};
    d.targetPos = {4, 2, -1};
    d.width = 640;
    d.height = 480;
    auto cam = Camera::create(d);
    ASSERT_TRUE(cam.isOk());
    Vec2 px;
    ASSERT_TRUE(cam->projectToPixel(d.targetPos, &px));
    EXPECT_NEAR(px.x, 320.0f, 1e-3f);
    EXPECT_NEAR(px.y, 240.0f, 1e-3f);
    // A point above the target appears above the centre (smaller y), one to the right at larger x.
    ASSERT_TRUE(cam->projectToPixel(d.targetPos + Vec3(0, 1, 0), &px));
    EXPECT_LT(px.y, 240.0f);
    ASSERT_TRUE(cam->projectToPixel(d.targetPos + cam->rightDir(), &px));
    EXPECT_GT(px.x, 320.0f);
    // Clip w equals the view-space distance along the viewing direction.
    Vec4 clip = cam->clipFromWorld() * Vec4(d.targetPos, 1.0f);
    EXPECT_NEAR(clip.w, 5.0f, 1e-4f);
}

TEST(Camera, PrincipalShiftMovesImageCentre) {
    CameraDesc d;
    d.width = 200;
    d.height = 100;
    d.principalShiftPx = {10.0f, -4.0f};
    auto cam = Camera::create(d);
    ASSERT_TRUE(cam.isOk());
    Vec2 px;
    ASSERT_TRUE(cam->projectToPixel(d.targetPos, &px));
    EXPECT_NEAR(px.x, 110.0f, 1e-3f);
    EXPECT_NEAR(px.y, 46.0f, 1e-3f);
}

TEST(Camera, RejectsBadParameters) {
    CameraDesc d;
    d.targetPos = d.eyePos;
    EXPECT_FALSE(Camera::create(d).isOk());
    d = {};
    d.upDir = {0, 0, 1};  // parallel to the view direction
    EXPECT_FALSE(Camera::create(d).isOk());
    d = {};
    d.width = 0;
    EXPECT_FALSE(Camera::create(d).isOk());
    d = {};
    d.fovYDegrees = 180.0f;
    EXPECT_FALSE(Camera::create(d).isOk());
    d = {};
    d.eyePos.x = std::nanf("");
    EXPECT_FALSE(Camera::create(d).isOk());
}

TEST(Camera, HugeEyeIsNamedNotBlamedOnTheUpVector) {
    // At 1e38 the view direction's length overflows and the up vector looked parallel.
    CameraDesc d;
    d.eyePos = {1e38f, 1.0f, 1.0f};
    auto cam = Camera::create(d);
    ASSERT_FALSE(cam.isOk());
    EXPECT_EQ(cam.status().message(),
              "camera eye (1e+38, 1, 1) is too far from the origin: coordinates must lie within "
              "+-1e+15");
    d = {};
    d.targetPos = {0.0f, -3e15f, 0.0f};
    EXPECT_NE(Camera::create(d).status().message().find("camera target"), std::string::npos);
}

ByteImage randomImage(int w, int h, int channels, uint32_t seed) {
    std::mt19937 rng(seed);
    ByteImage img{w, h, channels, {}};
    img.bytes.resize(size_t(w) * h * channels);
    for (auto& b : img.bytes) b = uint8_t(rng());
    return img;
}

TEST(ImageIo, PngRoundTripAllChannelCounts) {
    for (int c = 1; c <= 4; ++c) {
        ByteImage img = randomImage(37, 11, c, 100 + c);
        auto png = encodePng(img, 9);
        ASSERT_TRUE(png.isOk());
        auto back = decodeImage(*png);
        ASSERT_TRUE(back.isOk()) << back.status().toString();
        EXPECT_EQ(*back, img) << "channels " << c;
    }
}

TEST(ImageIo, PngEncoderRefusesImagesThatDisagreeWithThemselves) {
    ByteImage zeroChannels = randomImage(4, 4, 1, 1);
    zeroChannels.channels = 0;
    ByteImage sevenChannels = randomImage(4, 4, 1, 1);
    sevenChannels.channels = 7;
    ByteImage shortBytes = randomImage(4, 4, 3, 1);
    shortBytes.bytes.resize(5);
    ByteImage negativeWidth = randomImage(4, 4, 3, 1);
    negativeWidth.width = -1;
    for (const ByteImage& img : {zeroChannels, sevenChannels, shortBytes, negativeWidth})
        EXPECT_EQ(encodePng(img).status().code(), ErrorCode::kInvalidArgument)
            << img.width << "x" << img.height << "x" << img.channels;
    EXPECT_EQ(encodePng(shortBytes).status().message(), "5 bytes for a 4x4 image of 3 channels");
}

TEST(ImageIo, EveryTruncatedPngPrefixFailsCleanly) {
    ByteImage img = randomImage(9, 7, 3, 5);
    auto png = encodePng(img);
    ASSERT_TRUE(png.isOk());
    for (size_t n = 0; n < png->size(); ++n) {
        auto r = decodeImage(std::span(png->data(), n));
        // The final IEND chunk carries no pixels, so a few prefixes may still decode; what
        // matters is that none crashes and that a decoded image is the right one.
        if (r.isOk()) {
            EXPECT_EQ(*r, img);
        }
    }
}

TEST(ImageIo, RejectsGarbageAndMissingFiles) {
    std::vector<uint8_t> junk(100, 0x42);
    EXPECT_EQ(decodeImage(junk).status().code(), ErrorCode::kUnsupported);
    std::vector<uint8_t> fakeJpeg = {0xFF, 0xD8, 0xFF, 0xE0, 0, 0, 1, 2};
    EXPECT_EQ(decodeImage(fakeJpeg).status().code(), ErrorCode::kCorruptData);
    EXPECT_EQ(readImage("/nonexistent/file.png").status().code(), ErrorCode::kNotFound);
}

TEST(ImageIo, DecodesRealJpegTexture) {
    std::string path = std::string(PLX_SHARED_DATA_DIR) +
                       "/textures/sponza/10381718147657362067.jpg";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared data absent: " << path;
    auto img = readImage(path);
    ASSERT_TRUE(img.isOk()) << img.status().toString();
    EXPECT_GT(img->width, 0);
    EXPECT_EQ(img->channels, 3);
    auto bytes = readFileBytes(path);
    ASSERT_TRUE(bytes.isOk());
    for (size_t n : {size_t(0), size_t(10), bytes->size() / 3})
        (void)decodeImage(std::span(bytes->data(), n));  // must not crash
    // Cut after its header, libjpeg warns and fills the rest with grey: refused, not decoded.
    auto cut = decodeImage(std::span(bytes->data(), bytes->size() / 2));
    ASSERT_FALSE(cut.isOk());
    EXPECT_NE(cut.status().message().find("damaged data (Premature end of JPEG file)"),
              std::string::npos)
        << cut.status().message();
}

// Every JPEG texture of the shared Sponza decodes without a damaged-data warning.
TEST(ImageIo, RealJpegTexturesHaveNoDamage) {
    const std::filesystem::path dir = std::string(PLX_SHARED_DATA_DIR) + "/textures/sponza";
    if (!std::filesystem::exists(dir)) GTEST_SKIP() << "shared data absent: " << dir;
    int decoded = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (entry.path().extension() != ".jpg") continue;
        auto img = readImage(entry.path().string());
        EXPECT_TRUE(img.isOk()) << entry.path() << ": " << img.status().message();
        ++decoded;
    }
    EXPECT_GT(decoded, 0);
}

TEST(Metrics, PsnrAndDiffCounts) {
    Image<Rgba8> a(4, 4, Rgba8{100, 100, 100, 255});
    Image<Rgba8> b = a;
    EXPECT_TRUE(std::isinf(psnr(a, b)));
    b.at(1, 2) = {110, 100, 100, 255};
    ImageDiffStats s = compareImages(a, b);
    EXPECT_EQ(s.differingPixels, 1);
    EXPECT_EQ(s.maxChannelDifference, 10);
    // MSE = 100 / 48 samples.
    EXPECT_NEAR(s.psnrDb, 10.0 * std::log10(255.0 * 255.0 * 48.0 / 100.0), 1e-9);
    EXPECT_EQ(compareImages(a, b, 10).differingPixels, 0);
    Image<Rgba8> d = diffImage(a, b, 1.0f);
    EXPECT_EQ(d.at(1, 2).r, 10);
    EXPECT_EQ(d.at(0, 0).r, 0);
}

TEST(Color, SrgbTablesMatchExactCurves) {
    for (int i = 0; i < 256; ++i) {
        float lin = srgbDecodeTable()[i];
        EXPECT_EQ(encodeSrgb8(lin), i) << i;
    }
    EXPECT_EQ(encodeSrgb8(std::nanf("")), 0);
    EXPECT_EQ(encodeSrgb8(7.0f), 255);
}

TEST(Parallel, ParallelForVisitsEveryIndexOnce) {
    ThreadPool pool(2);
    std::vector<int> hits(10007, 0);
    pool.parallelFor(hits.size(), 64, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) hits[i]++;
    });
    for (int h : hits) ASSERT_EQ(h, 1);
}

TEST(Parallel, ThreadCountsTheAddressSpaceCannotHoldAreRefused) {
    EXPECT_TRUE(checkThreadCount(0, "threads").isOk());
    if (!addressSpaceRemaining()) {
        EXPECT_TRUE(checkThreadCount(kMaxThreads, "threads").isOk());
    }
    for (int bad : {-1, kMaxThreads + 1})
        EXPECT_NE(checkThreadCount(bad, "--threads").message().find("outside 0 .. 1024"),
                  std::string::npos);
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "no address space limit leaves AddressSanitizer its shadow";
#endif
    // 256 MiB beyond what the process maps (ulimit -v): room for a few threads, not for 64,
    // whose stacks alone take 252 MiB. A worker that could not start would end the process.
    rlimit saved{};
    ASSERT_EQ(getrlimit(RLIMIT_AS, &saved), 0);
    const uint64_t limit = mappedBytes() + (uint64_t(256) << 20);
    if (saved.rlim_cur != RLIM_INFINITY && saved.rlim_cur < limit)
        GTEST_SKIP() << "the address space limit is already below " << limit << " bytes";
    rlimit lowered = saved;
    lowered.rlim_cur = limit;
    ASSERT_EQ(setrlimit(RLIMIT_AS, &lowered), 0);
    const Status two = checkThreadCount(2, "threads");
    const Status many = checkThreadCount(64, "--threads");
    // 1 MiB beyond: not even a second thread's stack; 0 (all cores) says how many it means.
    lowered.rlim_cur = mappedBytes() + (uint64_t(1) << 20);
    ASSERT_EQ(setrlimit(RLIMIT_AS, &lowered), 0);
    const Status allCores = checkThreadCount(0, "--threads");
    ASSERT_EQ(setrlimit(RLIMIT_AS, &saved), 0);
    if (tbb::info::default_concurrency() >= 2) {
        EXPECT_NE(allCores.message().find("--threads 0 ("), std::string::npos)
            << allCores.message();
    }
    EXPECT_TRUE(two.isOk()) << two.toString();
    EXPECT_NE(many.message().find("--threads 64: the threads reserve about"), std::string::npos)
        << many.message();
    EXPECT_NE(many.message().find("(ulimit -v)"), std::string::npos);
    EXPECT_EQ(many.message().find('\n'), std::string::npos);
}

TEST(Parallel, PoolRunsAsManyThreadsAsAskedEvenBeyondTheCores) {
    // Every task waits until all are running, so they meet only if the pool runs them all at
    // once; a bounded wait turns a pool held to the cores into a failure, not a hang.
    const int threads = int(std::thread::hardware_concurrency()) + 2;
    ThreadPool pool(threads);
    ASSERT_EQ(pool.threadCount(), threads);
    std::atomic<int> running{0}, mostAtOnce{0};
    pool.parallelFor(size_t(threads), 1, [&](size_t, size_t) {
        const int now = ++running;
        for (int most = mostAtOnce.load();
             now > most && !mostAtOnce.compare_exchange_weak(most, now);) {
        }
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (mostAtOnce.load() < threads && std::chrono::steady_clock::now() < deadline)
            std::this_thread::sleep_for(std::chrono::microseconds(100));
        --running;
    });
    EXPECT_EQ(mostAtOnce.load(), threads) << "tasks running at once";
}

}  // namespace
}  // namespace plx

namespace plx {
namespace {

Camera centreCamera() {
    CameraDesc d;
    d.eyePos = {0, 1, 0};
    d.targetPos = {0, 1, -10};
    d.width = 640;
    d.height = 480;
    d.fovYDegrees = 60.0f;
    return *Camera::create(d);
}

TEST(StereoRig, ZeroDisparityAtConvergenceDistance) {
    StereoRigDesc desc;
    desc.separation = 0.07f;
    desc.convergence = 4.0f;
    auto rig = StereoRig::create(centreCamera(), desc);
    ASSERT_TRUE(rig.isOk());
    float f = 240.0f / std::tan(radians(30.0f));
    EXPECT_NEAR(rig->projectionDistancePx(), f, 1e-3f);
    EXPECT_NEAR(rig->imageShiftPx(), 0.07f * f / 8.0f, 1e-4f);  // e f / 2c
    for (Vec3 p : {Vec3(0, 1, -4), Vec3(1.2f, 0.3f, -4), Vec3(-0.7f, 2.0f, -4)}) {
        Vec2 l, r;
        ASSERT_TRUE(rig->left().projectToPixel(p, &l));
        ASSERT_TRUE(rig->right().projectToPixel(p, &r));
        EXPECT_NEAR(l.x, r.x, 2e-3f) << "point at the convergence distance";
        EXPECT_NEAR(l.y, r.y, 1e-3f) << "no vertical parallax";
    }
    // Eq. (1): disparity e f (1/c - 1/Z) elsewhere; nearer points have crossed (negative) disparity.
    for (float z : {1.5f, 8.0f, 40.0f}) {
        Vec2 l, r;
        Vec3 p(0.3f, 1.4f, -z);
        ASSERT_TRUE(rig->left().projectToPixel(p, &l));
        ASSERT_TRUE(rig->right().projectToPixel(p, &r));
        EXPECT_NEAR(r.x - l.x, rig->disparityPx(z), 2e-3f) << z;
        EXPECT_NEAR(l.y, r.y, 1e-3f);
    }
    EXPECT_LT(rig->disparityPx(1.0f), 0.0f);
    EXPECT_GT(rig->disparityPx(10.0f), 0.0f);
}

TEST(StereoRig, ParallelRigHasNoShiftAndEyesOffsetAlongRight) {
    StereoRigDesc desc;
    desc.type = StereoRigType::kParallel;
    desc.separation = 0.1f;
    auto rig = StereoRig::create(centreCamera(), desc);
    ASSERT_TRUE(rig.isOk());
    EXPECT_EQ(rig->imageShiftPx(), 0.0f);
    EXPECT_NEAR(glm::length(rig->right().eyePos() - rig->left().eyePos()), 0.1f, 1e-6f);
    EXPECT_NEAR(rig->right().eyePos().x - rig->left().eyePos().x, 0.1f, 1e-6f);
    EXPECT_EQ(rig->left().forwardDir(), rig->right().forwardDir());
    Vec2 l, r;
    ASSERT_TRUE(rig->left().projectToPixel({0, 1, -5}, &l));
    ASSERT_TRUE(rig->right().projectToPixel({0, 1, -5}, &r));
    EXPECT_NEAR(r.x - l.x, rig->disparityPx(5.0f), 2e-3f);
}

TEST(StereoRig, FirstEyeIsAParameterAndBadValuesAreRejected) {
    StereoRigDesc desc;
    desc.firstEye = Eye::kRight;
    auto rig = StereoRig::create(centreCamera(), desc);
    ASSERT_TRUE(rig.isOk());
    EXPECT_EQ(rig->first().eyePos(), rig->right().eyePos());
    EXPECT_EQ(rig->second().eyePos(), rig->left().eyePos());
    desc.separation = -0.01f;
    EXPECT_FALSE(StereoRig::create(centreCamera(), desc).isOk());
    // Valid numbers whose eye a camera cannot hold: the message names the separation.
    desc.separation = 1e30f;
    auto far = StereoRig::create(centreCamera(), desc);
    ASSERT_FALSE(far.isOk());
    EXPECT_EQ(far.status().message().rfind("eye separation 1e+30 puts the left eye out of range: "
                                           "camera eye",
                                           0),
              0u)
        << far.status().message();
    desc.separation = 0.06f;
    desc.convergence = 0.0f;
    EXPECT_FALSE(StereoRig::create(centreCamera(), desc).isOk());
    desc.convergence = std::nanf("");
    EXPECT_FALSE(StereoRig::create(centreCamera(), desc).isOk());
    EXPECT_FALSE(parseStereoRigType("sideways").isOk());
    desc.convergence = 3.0f;
    desc.type = StereoRigType(2);  // a number cast in, not read as the parallel rig
    EXPECT_FALSE(StereoRig::create(centreCamera(), desc).isOk());
    desc.type = StereoRigType::kParallel;
    desc.firstEye = Eye(-1);
    EXPECT_FALSE(StereoRig::create(centreCamera(), desc).isOk());
}

}  // namespace
}  // namespace plx
