// plx_gl_peer: times Mesa llvmpipe (OpenGL 4.5 through EGL, no display) drawing a scene with the
// same flat shading and the same three targets as Parallax's software rasterizer, one glFinish
// per frame. Prints the median frame time and triangles per second (text, or --json).
//
//   plx_gl_peer --procedural 1000000 --size 1280x720 --threads 2 --frames 20
//   plx_gl_peer --scene-file ../shared/data/models/DamagedHelmet/DamagedHelmet.glb

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <plx/gl/gl_renderer.h>

namespace {

using namespace plx;

constexpr long kMaxProceduralTriangles = 200'000'000;

// Sphere set: an 8 x 5 grid of UV spheres (fewer for tiny requests) sharing the triangles
// out, each with `stacks` rings and 2 * stacks slices, giving 2 * slices * (stacks - 1) =
// 4 * stacks * (stacks - 1) triangles per sphere. The grid is fixed so that, seen by
// frontCamera(), every triangle count covers the same pixels: only the tessellation density
// (pixels per triangle) changes between a 50k and a 1M request.
Result<scene::Scene> sphereSet(long triangles) {
    if (triangles < 24 || triangles > kMaxProceduralTriangles) {
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("--procedural {} outside [24, {}]", triangles, kMaxProceduralTriangles));
    }
    constexpr int kColumns = 8, kRows = 5;
    int spheres = int(std::min<long>(kColumns * kRows, triangles / 24));
    double perSphere = double(triangles) / spheres;
    // Solve 4 s (s - 1) = perSphere for the ring count s.
    int stacks = std::max(3, int(std::lround(0.5 + std::sqrt(0.25 + perSphere / 4.0))));
    int slices = 2 * stacks;
    int columns = std::min(spheres, kColumns);
    int rows = (spheres + columns - 1) / columns;

    scene::Scene scene;
    for (int i = 0; i < 8; ++i) {
        float hue = float(i) / 8.0f;
        Vec3 rgb = glm::clamp(
            Vec3(std::abs(hue * 6 - 3) - 1, 2 - std::abs(hue * 6 - 2), 2 - std::abs(hue * 6 - 4)),
            0.0f, 1.0f);
        scene.materials.push_back({fmt::format("hue{}", i), Vec4(0.15f + 0.7f * rgb, 1.0f), -1});
    }
    for (int k = 0; k < spheres; ++k) {
        scene::Mesh mesh;
        mesh.name = fmt::format("sphere{}", k);
        mesh.materialIndex = k % 8;
        Vec3 centre(float(k % columns) - 0.5f * float(columns - 1),
                    0.5f * float(rows - 1) - float(k / columns), 0.0f);
        for (int i = 0; i <= stacks; ++i) {
            float theta = kPi * float(i) / float(stacks);
            for (int j = 0; j <= slices; ++j) {
                float phi = 2.0f * kPi * float(j) / float(slices);
                Vec3 dir(std::sin(theta) * std::cos(phi), std::cos(theta),
                         std::sin(theta) * std::sin(phi));
                mesh.positions.push_back(centre + 0.45f * dir);
                mesh.normals.push_back(dir);
            }
        }
        auto vertex = [&](int i, int j) { return uint32_t(i * (slices + 1) + j); };
        for (int i = 0; i < stacks; ++i) {
            for (int j = 0; j < slices; ++j) {
                uint32_t a = vertex(i, j), b = vertex(i + 1, j), c = vertex(i + 1, j + 1),
                         d = vertex(i, j + 1);
                if (i != 0) mesh.indices.insert(mesh.indices.end(), {a, b, d});
                if (i != stacks - 1) mesh.indices.insert(mesh.indices.end(), {d, b, c});
            }
        }
        scene.meshes.push_back(std::move(mesh));
    }
    PLX_RETURN_IF_ERROR(scene.finalize());
    return scene;
}

// Triangles and base colours of a model file through assimp, every node's transform applied.
Result<scene::Scene> loadModel(const std::string& path) {
    const aiScene* ai =
        aiImportFile(path.c_str(), aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                       aiProcess_PreTransformVertices | aiProcess_SortByPType);
    if (ai == nullptr) {
        return errorStatus(ErrorCode::kIoError,
                           fmt::format("cannot import '{}': {}", path, aiGetErrorString()));
    }
    scene::Scene scene;
    for (unsigned m = 0; m < ai->mNumMaterials; ++m) {
        aiColor4D colour(0.8f, 0.8f, 0.8f, 1.0f);
        if (aiGetMaterialColor(ai->mMaterials[m], AI_MATKEY_BASE_COLOR, &colour) != AI_SUCCESS) {
            aiGetMaterialColor(ai->mMaterials[m], AI_MATKEY_COLOR_DIFFUSE, &colour);
        }
        scene.materials.push_back(
            {fmt::format("material{}", m), Vec4(colour.r, colour.g, colour.b, colour.a), -1});
    }
    for (unsigned m = 0; m < ai->mNumMeshes; ++m) {
        const aiMesh* in = ai->mMeshes[m];
        scene::Mesh mesh;
        mesh.name = in->mName.C_Str();
        mesh.materialIndex = int(in->mMaterialIndex);
        for (unsigned v = 0; v < in->mNumVertices; ++v) {
            mesh.positions.push_back({in->mVertices[v].x, in->mVertices[v].y, in->mVertices[v].z});
        }
        for (unsigned f = 0; f < in->mNumFaces; ++f) {
            const aiFace& face = in->mFaces[f];
            if (face.mNumIndices == 3) {
                mesh.indices.insert(mesh.indices.end(),
                                    {face.mIndices[0], face.mIndices[1], face.mIndices[2]});
            }
        }
        if (!mesh.indices.empty()) scene.meshes.push_back(std::move(mesh));
    }
    aiReleaseImport(ai);
    Status status = scene.finalize();
    if (!status) {
        return errorStatus(status.code(), fmt::format("'{}': {}", path, status.message()));
    }
    return scene;
}

// Looks down -z at the scene's bounds, from just far enough that they fill the image's width or
// height (5% margin); suits the flat sphere grid.
Result<Camera> frontCamera(const scene::Scene& scene, int width, int height) {
    CameraDesc desc;
    desc.width = width;
    desc.height = height;
    Vec3 extent = scene.bounds().extent(), centre = scene.bounds().center();
    float tanHalf = std::tan(radians(desc.fovYDegrees) * 0.5f);
    float aspect = float(width) / float(height);
    float distance =
        1.05f * std::max(0.5f * extent.y / tanHalf, 0.5f * extent.x / (tanHalf * aspect));
    desc.targetPos = centre;
    desc.eyePos = centre + Vec3(0.0f, 0.0f, 0.5f * extent.z + distance);
    scene::clipPlanesFor(scene.bounds(), desc.eyePos, &desc.nearPlane, &desc.farPlane);
    return Camera::create(desc);
}

Result<Camera> framingCamera(const scene::Scene& scene, int width, int height) {
    return scene::cameraAt(scene, scene::framingViewpoint(scene.bounds()), width, height);
}

struct Options {
    std::string sceneFile;
    long procedural = 0;
    std::string size = "1280x720";
    int threads = 2;
    int frames = 20;
    std::string writeColor;
    std::string writeIds;
    bool json = false;
};

Status run(const Options& options) {
    auto size = parseImageSize(options.size);
    if (!size) return errorStatus(size.status().code(), "--size: " + size.status().message());
    const int width = size->x, height = size->y;
    Result<scene::Scene> scene =
        options.sceneFile.empty() ? sphereSet(options.procedural) : loadModel(options.sceneFile);
    if (!scene) return scene.status();
    auto camera = options.sceneFile.empty() ? frontCamera(*scene, width, height)
                                            : framingCamera(*scene, width, height);
    if (!camera) return camera.status();

    gl::GlConfig config;
    config.threads = options.threads;
    auto renderer = gl::GlRenderer::create(config);
    if (!renderer) return renderer.status();
    PLX_RETURN_IF_ERROR((*renderer)->upload(*scene));
    auto timing = (*renderer)->timeFrames(*camera, options.frames);
    if (!timing) return timing.status();

    Image<Rgba8> color;
    Image<uint32_t> ids;
    if (!options.writeColor.empty() || !options.writeIds.empty()) {
        auto stats = (*renderer)->render(*camera, {&color, &ids, nullptr});
        if (!stats) return stats.status();
    }
    if (!options.writeColor.empty()) PLX_RETURN_IF_ERROR(writePng(options.writeColor, color));
    if (!options.writeIds.empty()) {
        // Visible triangles in pseudo-random colours (an integer hash of the ID), 0 black.
        Image<Rgba8> falseColor(ids.width(), ids.height());
        for (int y = 0; y < ids.height(); ++y) {
            for (int x = 0; x < ids.width(); ++x) {
                uint32_t h = ids.at(x, y) * 2654435761u;
                falseColor.at(x, y) = ids.at(x, y) == 0 ? Rgba8{0, 0, 0, 255}
                                                        : Rgba8{uint8_t(h >> 24), uint8_t(h >> 16),
                                                                uint8_t(h >> 8), 255};
            }
        }
        PLX_RETURN_IF_ERROR(writePng(options.writeIds, falseColor));
    }

    std::string source = options.sceneFile.empty()
                             ? fmt::format("procedural:{}", options.procedural)
                             : options.sceneFile;
    const gl::GlTiming& t = *timing;
    if (options.json) {
        nlohmann::json out = {{"renderer", (*renderer)->rendererName()},
                              {"version", (*renderer)->versionString()},
                              {"threads", (*renderer)->threads()},
                              {"scene", source},
                              {"triangles", t.trianglesPerFrame},
                              {"width", width},
                              {"height", height},
                              {"frames", t.frames},
                              {"median_ms", t.medianMs},
                              {"min_ms", t.minMs},
                              {"max_ms", t.maxMs},
                              {"mtri_per_s", t.trianglesPerSecond * 1e-6},
                              {"mpix_per_s", double(width) * height / (t.medianMs * 1e3)}};
        fmt::print("{}\n", out.dump(2));
    } else {
        fmt::print("renderer   {} ({}), LP_NUM_THREADS={}\n", (*renderer)->rendererName(),
                   (*renderer)->versionString(), (*renderer)->threads());
        fmt::print("scene      {}: {} triangles, {} meshes, {}x{}\n", source, t.trianglesPerFrame,
                   scene->meshes.size(), width, height);
        fmt::print("frames     {}: median {:.2f} ms (min {:.2f}, max {:.2f})\n", t.frames,
                   t.medianMs, t.minMs, t.maxMs);
        fmt::print("throughput {:.2f} Mtri/s, {:.1f} Mpix/s\n", t.trianglesPerSecond * 1e-6,
                   double(width) * height / (t.medianMs * 1e3));
    }
    return Status::ok();
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "Time Mesa llvmpipe (OpenGL 4.5 via EGL) on the software rasterizer's workload.\n"
        "Example: plx_gl_peer --procedural 1000000 --size 1280x720 --threads 2"};
    Options options;
    auto* file = app.add_option("--scene-file", options.sceneFile, "model file (assimp)");
    auto* procedural = app.add_option("--procedural", options.procedural,
                                      "triangle count of a generated sphere set");
    file->excludes(procedural);
    procedural->excludes(file);
    app.add_option("--size", options.size, "image size WxH")->capture_default_str();
    app.add_option("--threads", options.threads, "llvmpipe threads (LP_NUM_THREADS); 0: all")
        ->capture_default_str();
    app.add_option("--frames", options.frames, "timed frames after one warm-up")
        ->capture_default_str();
    app.add_option("--write-color", options.writeColor, "PNG of the last frame's colour");
    app.add_option("--write-ids", options.writeIds, "PNG of the last frame's IDs, false colour");
    app.add_flag("--json", options.json, "machine-readable result on stdout");
    CLI11_PARSE(app, argc, argv);
    if (options.sceneFile.empty() && options.procedural == 0) {
        fmt::print(stderr, "error: give --scene-file PATH or --procedural N\n");
        return 2;
    }
    Status status = run(options);
    if (!status) {
        fmt::print(stderr, "error: {}\n", status.toString());
        return 1;
    }
    return 0;
}
