// Tests of the display module: optics round trips, quadtree meshes (crack-free, balanced, error
// bound on random viewpoints), containers, display JSON errors and mesh interchange.

#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include <plx/core/image_io.h>

#include <plx/core/parallel.h>
#include <plx/display/container.h>
#include <plx/display/display_json.h>
#include <plx/display/mesh_io.h>
#include <plx/display/predistort.h>
#include <plx/display/quadtree.h>
#include <plx/display/validate.h>
#include <plx/scene/generators.h>

#include "../src/brent.h"

namespace plx::display {
namespace {

std::string examplePath(const std::string& name) {
    return std::string(PLX_SOURCE_DIR) + "/examples/displays/" + name;
}

Display loadExample(const std::string& name) {
    auto d = loadDisplayFile(examplePath(name));
    EXPECT_TRUE(d.isOk()) << d.status().toString();
    return d.isOk() ? *d : Display{};
}

// A viewer position around the display: azimuth and height varied about the default.
DVec3 randomViewer(const Display& d, std::mt19937& rng) {
    std::uniform_real_distribution<double> az(-0.5, 0.5), dy(-60.0, 60.0);
    DVec3 e = d.defaultViewerMm - d.contentCenterMm;
    double a = az(rng);
    DVec3 r(e.x * std::cos(a) - e.z * std::sin(a), e.y + dy(rng), e.x * std::sin(a) + e.z * std::cos(a));
    return d.contentCenterMm + r;
}

TEST(Brent, FindsParabolaMinimum) {
    auto f = [](double x) { return (x - 0.3) * (x - 0.3) + 1.0; };
    BrentResult r = brentMinimize(f, -2.0, 3.0, 10.0, 1e-10, 0.0, 100);
    EXPECT_NEAR(r.x, 0.3, 1e-6);
    EXPECT_LT(r.evaluations, 40);
}

TEST(DisplayJson, ExamplesLoad) {
    for (const char* name : {"cone_showcase.json", "cylinder_mirror.json", "cylinder_screen.json",
                             "dome_screen.json"}) {
        auto d = loadDisplayFile(examplePath(name));
        ASSERT_TRUE(d.isOk()) << name << ": " << d.status().toString();
    }
    Display cone = loadExample("cone_showcase.json");
    EXPECT_EQ(opticsKindName(cone), "cone_mirror");
    Display dome = loadExample("dome_screen.json");
    EXPECT_EQ(opticsKindName(dome), "dome_screen");
    // Metres are converted to millimetres.
    EXPECT_NEAR(std::get<DomeScreen>(std::get<ProjectedScreen>(dome.optics).surface).radiusMm,
                2500.0, 1e-9);
}

TEST(DisplayJson, EveryPrefixOfAnExampleFailsCleanly) {
    auto bytes = readFileBytes(examplePath("cone_showcase.json"));
    ASSERT_TRUE(bytes.isOk());
    std::string text(bytes->begin(), bytes->end());
    ASSERT_TRUE(parseDisplayJson(text).isOk());
    size_t end = text.find_last_of('}');
    for (size_t cut = 0; cut < end; ++cut) {
        auto r = parseDisplayJson(text.substr(0, cut));
        ASSERT_FALSE(r.isOk()) << "prefix " << cut;
        EXPECT_EQ(r.status().message().find('\n'), std::string::npos) << r.status().message();
    }
}

TEST(DisplayJson, MalformedFilesGiveOneLineErrors) {
    const std::string good = R"({"optics": {"type": "cone_mirror", "bottom_radius": 150,
        "top_radius": 250, "height": 400}, "display": {"min": [-600, -600], "max": [600, 600],
        "framebuffer": [512, 512]}, "viewer": [0, 450, 800],
        "content": {"center": [0, 200, 0], "radius": 150}})";
    ASSERT_TRUE(parseDisplayJson(good).isOk()) << parseDisplayJson(good).status().toString();
    struct Case {
        std::string from, to, expect;
    };
    const Case cases[] = {
        {"\"bottom_radius\": 150", "\"bottom_radius\": -150", "optics.bottom_radius"},
        {"\"bottom_radius\": 150,", "", "optics.bottom_radius: missing"},
        {"\"height\": 400", "\"height\": \"tall\"", "optics.height: must be a number"},
        {"\"height\": 400", "\"height\": NaN", "not valid JSON"},
        {"\"height\": 400", "\"height\": 1e999", "not valid JSON"},
        {"\"viewer\": [0, 450, 800]", "\"viewer\": [0, 450]", "viewer: must be [x, y, z]"},
        {"\"viewer\": [0, 450, 800]", "\"viewer\": [0, 200, 0]", "viewer"},
        {"\"cone_mirror\"", "\"paraboloid\"", "optics.type: unknown type"},
        // Names quoted in the message keep it one line: escaped newlines and tabs become '?'.
        {"\"cone_mirror\"", "\"cone\\nmirror\"", "unknown type 'cone?mirror'"},
        {"{\"optics\"", "{\"units\": \"m\\tm\", \"optics\"", "unknown unit 'm?m'"},
        {"\"framebuffer\": [512, 512]", "\"framebuffer\": [0, 512]", "display.framebuffer"},
        {"\"radius\": 150}", "\"radius\": 0}", "content.radius"},
        {"\"top_radius\": 250", "\"top_radius\": 100", "optics.top_radius"},
        // Lengths beyond float coordinates (1e39 mm stopped predistort on a failed check), or
        // beyond 10 km.
        {"\"center\": [0, 200, 0]", "\"center\": [0, 1e39, 0]",
         "content.center: must lie within +-1e+07 mm"},
        {"\"viewer\": [0, 450, 800]", "\"viewer\": [0, 450, -1e300]", "viewer: must lie within"},
        {"\"min\": [-600, -600]", "\"min\": [-600, -2e7]", "display.min: must lie within"},
        {"\"height\": 400", "\"height\": 2e7", "optics.height: must lie within"},
    };
    for (const Case& c : cases) {
        std::string text = good;
        size_t at = text.find(c.from);
        ASSERT_NE(at, std::string::npos) << c.from;
        text.replace(at, c.from.size(), c.to);
        auto r = parseDisplayJson(text);
        ASSERT_FALSE(r.isOk()) << c.to;
        EXPECT_NE(r.status().message().find(c.expect), std::string::npos)
            << r.status().message();
        EXPECT_EQ(r.status().message().find('\n'), std::string::npos);
    }
    EXPECT_FALSE(parseDisplayJson("[1, 2]").isOk());
    EXPECT_FALSE(parseDisplayJson("").isOk());
    EXPECT_FALSE(loadDisplayFile("/nonexistent/display.json").isOk());
}

// Displays built in code get the checks their files get (a -1x64 framebuffer was accepted, and
// the renderer failed later without naming the display).
TEST(DisplayJson, ValidateRefusesWhatParsingRefuses) {
    auto refused = [](const Display& d, const std::string& expect) {
        Status s = validateDisplay(d);
        EXPECT_FALSE(s.isOk()) << expect;
        EXPECT_NE(s.message().find(expect), std::string::npos) << s.message();
    };
    Display cone = loadExample("cone_showcase.json");
    ASSERT_TRUE(validateDisplay(cone).isOk());
    Display d = cone;
    d.framebufferWidth = -1;
    refused(d, "display.framebuffer: pixel sizes must lie in [1, 16384]");
    d = cone;
    d.framebufferHeight = 20000;
    refused(d, "display.framebuffer");
    d = cone;
    std::get<ConeMirror>(d.optics).heightMm = 0.0;
    refused(d, "positive height");
    d = cone;
    std::get<ConeMirror>(d.optics).refractiveIndex = 0.5;
    refused(d, "optics.sheet.refractive_index: must lie in [1, 4]");

    Display dome = loadExample("dome_screen.json");
    ASSERT_TRUE(validateDisplay(dome).isOk());
    d = dome;
    std::get<ProjectedScreen>(d.optics).projector.fovYDegrees = std::nan("");
    refused(d, "optics.projector.fov_y");
    d = dome;
    std::get<ProjectedScreen>(d.optics).projector.widthPx = 0;
    refused(d, "optics.projector.resolution");
    d = dome;
    auto& projector = std::get<ProjectedScreen>(d.optics).projector;
    projector.upDir = projector.targetMm - projector.posMm;
    refused(d, "optics.projector.up: must not be parallel");
}

// Object to image to object: the display point found for an image point maps back to it.
void checkRoundTrip(const Display& d, double tolMm) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u01(0.02, 0.98);
    for (int view = 0; view < 3; ++view) {
        ImagePlane plane = makeImagePlane(randomViewer(d, rng), d.contentCenterMm,
                                          d.contentRadiusMm);
        for (int i = 0; i < 200; ++i) {
            DVec2 uv(u01(rng), u01(rng));
            DVec3 p = plane.pointAt(uv);
            VertexMapping m = imageToDisplay(d, plane, p);
            ASSERT_TRUE(m.valid);
            DVec3 back;
            double residual;
            SolverStats stats;
            ASSERT_TRUE(displayToImage(d, plane, m.displayPos, {m.alpha - 0.05, m.alpha + 0.05},
                                       &back, &residual, &stats));
            EXPECT_LT(glm::length(back - p), tolMm) << opticsKindName(d) << " uv " << uv.x
                                                    << "," << uv.y;
        }
    }
}

TEST(Optics, ReflectionRoundTrip) { checkRoundTrip(loadExample("cone_showcase.json"), 0.01); }

TEST(Optics, ReflectionRoundTripWithRefraction) {
    Display d = loadExample("cone_showcase.json");
    std::get<ConeMirror>(d.optics).sheetThicknessMm = 3.0;
    checkRoundTrip(d, 0.01);
    // Refraction moves the displayed point (the sheet shifts the line of sight).
    Display flat = loadExample("cone_showcase.json");
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    DVec3 p = plane.pointAt({0.3, 0.4});
    double shift = glm::length(imageToDisplay(d, plane, p).displayPos -
                               imageToDisplay(flat, plane, p).displayPos);
    EXPECT_GT(shift, 0.1);
}

TEST(Optics, ScreenRoundTrips) {
    checkRoundTrip(loadExample("cylinder_screen.json"), 1e-6);
    checkRoundTrip(loadExample("dome_screen.json"), 1e-6);
    checkRoundTrip(loadExample("cylinder_mirror.json"), 0.01);
}

void expectCrackFree(const WarpMesh& mesh, bool fullGrid) {
    CrackReport r = checkCracks(mesh);
    EXPECT_GT(mesh.triangleCount(), 0u);
    EXPECT_EQ(r.overusedEdges, 0u);
    EXPECT_EQ(r.tJunctions, 0u);
    if (fullGrid) {
        EXPECT_EQ(r.imageBorderViolations, 0u);
    }
}

TEST(Quadtree, CrackFreeAndBalanced) {
    Display d = loadExample("cone_showcase.json");
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    auto warper = QuadtreeWarper::create({8, 1.0, 99, 1});
    ASSERT_TRUE(warper.isOk());
    for (double thr : {4.0, 1.0, 0.3}) {
        (*warper)->setThresholdMm(thr);
        WarpMesh mesh;
        WarpStats stats;
        (*warper)->generate(d, plane, nullptr, &mesh, &stats);
        expectCrackFree(mesh, true);
        EXPECT_EQ(stats.leafPatches * 4 <= mesh.triangleCount(), true);
        EXPECT_EQ(stats.solver.failed, 0u);
        // Every vertex transformed once: the count equals the distinct vertices touched.
        EXPECT_GE(stats.vertexTransformations, mesh.vertexCount());
    }
}

TEST(Quadtree, UnbalancedRefinementIsRepaired) {
    // A tiny threshold with a shallow grid still forces sharp LOD changes near the silhouette;
    // balancing must leave no T-junction.
    Display d = loadExample("cone_showcase.json");
    d.contentRadiusMm = 175.0;
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    auto warper = QuadtreeWarper::create({7, 0.2, 99, 1});
    ASSERT_TRUE(warper.isOk());
    WarpMesh mesh;
    WarpStats stats;
    (*warper)->generate(d, plane, nullptr, &mesh, &stats);
    expectCrackFree(mesh, false);
}

TEST(Quadtree, ErrorBoundHoldsOnRandomViewpoints) {
    ThreadPool pool(2);
    std::mt19937 rng(11);
    for (const char* name : {"cone_showcase.json", "cylinder_screen.json", "dome_screen.json"}) {
        Display d = loadExample(name);
        // Every side sampled (Lambda off), and the defaults: Lambda = 3 with the re-check.
        // Grid level 9: level 8 cannot reach 0.1 mm on the cone at all.
        auto full = QuadtreeWarper::create({9, 1.0, 99, 1});
        auto directional = QuadtreeWarper::create({9, 1.0});
        ASSERT_TRUE(full.isOk() && directional.isOk());
        for (int view = 0; view < 3; ++view) {
            ImagePlane plane = makeImagePlane(randomViewer(d, rng), d.contentCenterMm,
                                              d.contentRadiusMm);
            for (QuadtreeWarper* warper : {full->get(), directional->get()}) {
                for (double thr : {2.0, 0.5, 0.1}) {
                    warper->setThresholdMm(thr);
                    WarpMesh mesh;
                    WarpStats stats;
                    warper->generate(d, plane, nullptr, &mesh, &stats);
                    expectCrackFree(mesh, true);
                    ErrorMeasurement e = measureMeshError(d, plane, mesh, 4, &pool);
                    EXPECT_LE(e.maxErrorMm, thr)
                        << name << " view " << view << " Lambda "
                        << warper->config().errorDirectionLevel;
                    EXPECT_EQ(e.unmapped, 0u);
                }
            }
        }
    }
}

TEST(Quadtree, ErrorDirectionHeuristicSavesSamples) {
    // Section 7.4 with Lambda = 3: patches above Lambda sample one side (plus the re-check near
    // the threshold), so far fewer error samples, while on the cone's well-behaved optics the
    // mesh stays the one that sampling every side gives.
    Display d = loadExample("cone_showcase.json");
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    auto full = QuadtreeWarper::create({9, 0.5, 99, 1});
    auto directional = QuadtreeWarper::create({9, 0.5, 3, 1});
    ASSERT_TRUE(full.isOk() && directional.isOk());
    WarpMesh meshFull, meshDir;
    WarpStats statsFull, statsDir;
    (*full)->generate(d, plane, nullptr, &meshFull, &statsFull);
    (*directional)->generate(d, plane, nullptr, &meshDir, &statsDir);
    EXPECT_LT(statsDir.errorSamples * 10, statsFull.errorSamples * 7);
    EXPECT_EQ(meshDir.gridIds, meshFull.gridIds);
    EXPECT_EQ(meshDir.indices, meshFull.indices);
}

TEST(Quadtree, UniformGridErrorShrinksQuadratically) {
    Display d = loadExample("cone_showcase.json");
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    ThreadPool pool(2);
    double previous = 0.0;
    for (int level = 3; level <= 6; ++level) {
        WarpMesh mesh;
        WarpStats stats;
        generateUniform(d, plane, level, &mesh, &stats);
        EXPECT_EQ(mesh.triangleCount(), size_t(2) << (2 * level));
        expectCrackFree(mesh, true);
        double e = measureMeshError(d, plane, mesh, 2, &pool).maxErrorMm;
        if (level > 3) {
            EXPECT_LT(e, 0.4 * previous);
        }
        previous = e;
    }
}

// Points of an off-centre ellipsoid inside the content sphere: the "scene".
std::vector<DVec3> scenePoints(const Display& d) {
    std::vector<DVec3> pts;
    std::mt19937 rng(3);
    std::normal_distribution<double> g;
    for (int i = 0; i < 2000; ++i) {
        DVec3 v(g(rng), g(rng), g(rng));
        v = glm::normalize(v) * std::cbrt(std::uniform_real_distribution<double>(0, 1)(rng));
        pts.push_back(d.contentCenterMm + DVec3(30.0, -20.0, 0.0) + v * DVec3(40.0, 90.0, 50.0));
    }
    return pts;
}

TEST(Container, ContainsItsPoints) {
    Display d = loadExample("cone_showcase.json");
    auto pts = scenePoints(d);
    for (ContainerKind kind : {ContainerKind::kObb, ContainerKind::kHull}) {
        Container c = makeContainer(kind, pts);
        ASSERT_GT(c.triangleCount(), 0u);
        for (const DVec3& p : pts) ASSERT_TRUE(containerContains(c, p, 1e-6)) << containerKindName(kind);
    }
    EXPECT_LE(makeHullContainer(pts).triangleCount(), 26u * 8u);
}

// Rays from one origin towards points of random triangles: a point inside (barycentric weights
// away from the edges) is hit at the distance to it, one outside (a negative weight) is missed,
// one behind the origin is missed; the prepared and the one-off tests agree on every ray.
TEST(Container, RaysFromOneOriginMeetTrianglesWhereExpected) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> coord(-100.0, 100.0), weight(0.05, 0.9);
    const DVec3 origin(3.0, -250.0, 40.0);
    int hits = 0, misses = 0;
    for (int trial = 0; trial < 500; ++trial) {
        DVec3 a(coord(rng), coord(rng), coord(rng)), b(coord(rng), coord(rng), coord(rng)),
            c(coord(rng), coord(rng), coord(rng));
        if (glm::length(glm::cross(b - a, c - a)) < 100.0) continue;  // skip slivers
        TriangleFromOrigin tri = prepareFromOrigin(origin, a, b, c);
        double u = weight(rng), v = weight(rng) * (1.0 - u);
        for (double su : {1.0, -1.0}) {  // -1: the point lies outside, beyond edge ac
            DVec3 target = a + (su * u) * (b - a) + v * (c - a);
            DVec3 d = target - origin;
            double t = -1.0, tOnce = -1.0;
            bool hit = intersectFromOrigin(tri, d, &t);
            ASSERT_EQ(hit, intersectTriangle(origin, d, a, b, c, &tOnce));
            ASSERT_EQ(hit, su > 0.0) << "trial " << trial;
            if (hit) {
                EXPECT_NEAR(t, 1.0, 1e-9);
                EXPECT_EQ(t, tOnce);
                ++hits;
            } else {
                ++misses;
            }
            double tBehind;
            EXPECT_FALSE(intersectFromOrigin(tri, -d, &tBehind));
        }
    }
    EXPECT_GT(hits, 100);
    EXPECT_GT(misses, 100);
}

bool insideTriangleUv(const WarpMesh& mesh, const DVec2& p) {
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        DVec2 a = mesh.uvs[mesh.indices[3 * t]], b = mesh.uvs[mesh.indices[3 * t + 1]],
              c = mesh.uvs[mesh.indices[3 * t + 2]];
        auto side = [](DVec2 o, DVec2 x, DVec2 y) {
            return (x.x - o.x) * (y.y - o.y) - (x.y - o.y) * (y.x - o.x);
        };
        double s0 = side(a, b, p), s1 = side(b, c, p), s2 = side(c, a, p);
        if ((s0 >= -1e-12 && s1 >= -1e-12 && s2 >= -1e-12) ||
            (s0 <= 1e-12 && s1 <= 1e-12 && s2 <= 1e-12))
            return true;
    }
    return false;
}

TEST(Container, NeverCullsPatchesShowingTheScene) {
    Display d = loadExample("cone_showcase.json");
    auto pts = scenePoints(d);
    std::mt19937 rng(5);
    for (ContainerKind kind : {ContainerKind::kObb, ContainerKind::kHull}) {
        Container c = makeContainer(kind, pts);
        auto warper = QuadtreeWarper::create({8, 1.0, 99, 1});
        ASSERT_TRUE(warper.isOk());
        for (int view = 0; view < 3; ++view) {
            ImagePlane plane = makeImagePlane(randomViewer(d, rng), d.contentCenterMm,
                                              d.contentRadiusMm);
            WarpMesh limited, full;
            WarpStats ls, fs;
            (*warper)->generate(d, plane, &c, &limited, &ls);
            (*warper)->generate(d, plane, nullptr, &full, &fs);
            expectCrackFree(limited, false);
            EXPECT_LT(limited.triangleCount(), full.triangleCount());
            EXPECT_GT(ls.culledPatches, 0u);
            for (size_t i = 0; i < pts.size(); i += 7) {
                DVec3 onPlane;
                ASSERT_TRUE(plane.projectFromEye(pts[i], &onPlane));
                EXPECT_TRUE(insideTriangleUv(limited, plane.uvOf(onPlane)))
                    << containerKindName(kind) << " point " << i;
            }
        }
    }
}

TEST(MeshIo, BourkeRoundTripAndObjPfm) {
    Display d = loadExample("cone_showcase.json");
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    auto warper = QuadtreeWarper::create({6, 2.0, 99, 1});
    ASSERT_TRUE(warper.isOk());
    WarpMesh mesh;
    WarpStats stats;
    (*warper)->generate(d, plane, nullptr, &mesh, &stats);
    WarpGrid grid = resampleToGrid(mesh, 5);
    for (float i : grid.intensity) EXPECT_GE(i, 0.0f);  // a full grid covers every node
    // Mesh vertices on the export grid keep their exact positions.
    for (size_t v = 0; v < mesh.vertexCount(); ++v) {
        DVec2 g = mesh.uvs[v] * 32.0;
        if (g.x != std::floor(g.x) || g.y != std::floor(g.y)) continue;
        size_t idx = size_t(g.y) * 33 + size_t(g.x);
        EXPECT_LT(glm::length(grid.displayPos[idx] - mesh.displayPos[v]), 1e-6);
    }
    std::string text = formatBourke(d, grid);
    auto parsed = parseBourke(d, text);
    ASSERT_TRUE(parsed.isOk()) << parsed.status().toString();
    ASSERT_EQ(parsed->nx, 33);
    for (size_t v = 0; v < grid.uvs.size(); ++v) {
        EXPECT_LT(glm::length(parsed->displayPos[v] - grid.displayPos[v]), 1e-4);
        EXPECT_LT(glm::length(parsed->uvs[v] - grid.uvs[v]), 1e-8);
    }
    EXPECT_EQ(meshFromGrid(*parsed).triangleCount(), size_t(2 * 32 * 32));
    // Truncated and corrupt files are refused with a line number: prefixes that end before the
    // last grid line (a cut inside the final number can still parse as a shorter number); every
    // one through the header and first rows, then every 37th (the file is ~50k characters).
    size_t lastLine = text.rfind('\n', text.size() - 2);
    for (size_t cut = 0; cut < lastLine; cut += cut < 2048 ? 1 : 37) {
        auto r = parseBourke(d, text.substr(0, cut));
        ASSERT_FALSE(r.isOk()) << "prefix " << cut;
        EXPECT_NE(r.status().message().find("line"), std::string::npos) << r.status().message();
    }
    EXPECT_FALSE(parseBourke(d, "2\n2 2\n0 0 0 0 1\n0 0 nan 0 1\n0 0 0 0 1\n0 0 0 0 1\n").isOk());
    std::string obj = formatObj(mesh);
    EXPECT_NE(obj.find("\nf "), std::string::npos);
    auto pfm = encodeWarpPfm(d, mesh, 64, 64);
    EXPECT_EQ(pfm.size(), std::string("PF\n64 64\n-1.0\n").size() + 64 * 64 * 12);
}

// Pass 2 draws the warp mesh colour-only (no depth test) and clears only the tiles drawn into;
// both rest on the warp not folding over. On every shipped display, from the default and random
// viewers, uniform and adaptive meshes (with and without the container) keep one orientation,
// and frame after frame (the viewer moving, meshes alternating) the frames equal those of the
// depth-tested, wholly cleared pass 2 byte for byte.
TEST(Predistort, ColorOnlyPassTwoEqualsDepthTestedFrames) {
    std::mt19937 rng(21);
    for (const char* name : {"cone_showcase.json", "cylinder_mirror.json", "cylinder_screen.json",
                             "dome_screen.json"}) {
        Display d = loadExample(name);
        scene::Scene scene = fitSceneToContent(*plx::scene::generateShowcase(), d);
        Container hull = makeContainer(ContainerKind::kHull, scenePointsMm(scene));
        auto fast = PredistortRenderer::create(2);
        auto tested = PredistortRenderer::create(1);
        auto warper = QuadtreeWarper::create({8, 1.0});
        ASSERT_TRUE(fast.isOk() && tested.isOk() && warper.isOk());
        (*tested)->setColorOnly(false);
        for (int view = 0; view < 4; ++view) {
            DVec3 eye = view == 0 ? d.defaultViewerMm : randomViewer(d, rng);
            ImagePlane plane = makeImagePlane(eye, d.contentCenterMm, d.contentRadiusMm);
            Image<Rgba8> pass1;
            ASSERT_TRUE(renderViewerImage((*tested)->renderer(), scene, plane, 128, &pass1,
                                          nullptr)
                            .isOk());
            WarpMesh meshes[3];
            WarpStats stats;
            generateUniform(d, plane, 5, &meshes[0], &stats);
            (*warper)->generate(d, plane, nullptr, &meshes[1], &stats);
            (*warper)->generate(d, plane, &hull, &meshes[2], &stats);
            for (int k = 0; k < 3; ++k) {
                const WarpMesh& mesh = meshes[k];
                std::string what = std::string(name) + " view " + std::to_string(view) +
                                   " mesh " + std::to_string(k);
                int sign = 0;
                bool folds = false;
                for (size_t t = 0; t < mesh.triangleCount(); ++t) {
                    const DVec2* p[3];
                    for (int c = 0; c < 3; ++c) p[c] = &mesh.displayPos[mesh.indices[3 * t + c]];
                    double area2 = (p[1]->x - p[0]->x) * (p[2]->y - p[0]->y) -
                                   (p[1]->y - p[0]->y) * (p[2]->x - p[0]->x);
                    int s = (area2 > 0.0) - (area2 < 0.0);
                    if (s != 0 && sign != 0 && s != sign) folds = true;
                    if (s != 0) sign = s;
                }
                EXPECT_FALSE(folds) << what;
                auto a = (*fast)->render(d, mesh, pass1);
                auto b = (*tested)->render(d, mesh, pass1);
                ASSERT_TRUE(a.isOk() && b.isOk()) << what;
                EXPECT_TRUE(**a == **b) << what;
            }
        }
    }
}

// Pass 1 rendered straight into viewerImage() gives, without a copy, the frame of the render
// that copies its image argument; before any pass-1 image the frame is black.
TEST(Predistort, RenderFromViewerImageEqualsRenderOfACopy) {
    Display d = loadExample("cone_showcase.json");
    scene::Scene scene = fitSceneToContent(*plx::scene::generateShowcase(), d);
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    auto inPlace = PredistortRenderer::create(2);
    auto copying = PredistortRenderer::create(2);
    ASSERT_TRUE(inPlace.isOk() && copying.isOk());
    WarpMesh mesh;
    WarpStats stats;
    generateUniform(d, plane, 5, &mesh, &stats);
    auto black = (*inPlace)->render(d, mesh);
    ASSERT_TRUE(black.isOk());
    EXPECT_EQ((*black)->width(), d.framebufferWidth);
    EXPECT_EQ((*black)->at(d.framebufferWidth / 2, d.framebufferHeight / 2),
              (Rgba8{0, 0, 0, 255}));
    ASSERT_TRUE(renderViewerImage((*inPlace)->renderer(), scene, plane, 128,
                                  &(*inPlace)->viewerImage(), nullptr)
                    .isOk());
    Image<Rgba8> pass1 = (*inPlace)->viewerImage();
    for (int frame = 0; frame < 2; ++frame) {
        auto a = (*inPlace)->render(d, mesh);
        auto b = (*copying)->render(d, mesh, pass1);
        ASSERT_TRUE(a.isOk() && b.isOk());
        EXPECT_TRUE(**a == **b) << "frame " << frame;
    }
    EXPECT_TRUE((*copying)->viewerImage() == pass1);
}

}  // namespace
}  // namespace plx::display

