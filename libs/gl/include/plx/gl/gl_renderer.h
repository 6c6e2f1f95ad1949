#pragma once
// OpenGL 4.5 peer of the software rasterizer: renders a Scene into the same three targets (sRGB
// colour, depth, polygon ID) through EGL on Mesa's surfaceless platform, so that it needs no
// display. On a machine without a GPU this is Mesa's llvmpipe, the multithreaded CPU rasterizer
// that the benchmarks compare Parallax's renderer against.
//
// Targets follow the Conventions block in <plx/core/core.h>: images have a top-left origin (GL's
// bottom-left rows are flipped on readback); the ID target holds the scene-global triangle index
// + 1 (0 = no polygon), computed as gl_PrimitiveID + firstTriangle(mesh) + 1; colour is shaded in
// linear RGB and encoded to sRGB in the fragment shader; the depth readback is converted to 1/w
// (0 = cleared), while GL itself depth-tests window z with GL_LESS in a 32-bit float buffer.
//
// A GlRenderer owns an OpenGL context that it makes current on the calling thread at each call;
// use one renderer from one thread at a time.

#include <cstdint>
#include <memory>
#include <string>

#include <plx/core/core.h>
#include <plx/scene/scene.h>

namespace plx::gl {

struct GlConfig {
    // llvmpipe rasterizer threads, passed as LP_NUM_THREADS before the first EGL initialisation
    // of the process. 0 leaves the environment alone (llvmpipe then uses every core).
    int threads = 0;
    // Refuse drivers other than Mesa's llvmpipe (the CPU peer that benchmarks compare against).
    bool requireLlvmpipe = false;
    // Shading, as the software renderer's flat mode: colour = base * (ambient + |n . l|) in
    // linear RGB, with n the face normal and l the normalised direction towards the light.
    Vec3 lightDir{0.35f, 0.85f, 0.4f};
    float ambient = 0.25f;
    Rgba8 clearColor{40, 44, 52, 255};  // sRGB-encoded, as stored in the colour target
};

// Optional readback destinations; each non-null image is resized to the camera's size and
// filled after the frame. Leave all null to render without readback (benchmarks).
struct GlTargets {
    Image<Rgba8>* color = nullptr;
    Image<uint32_t>* id = nullptr;
    Image<float>* depth = nullptr;  // 1/w (Conventions), 0 where nothing was drawn
};

struct GlFrameStats {
    uint64_t trianglesSubmitted = 0;  // triangles handed to glDrawElements*
    uint32_t drawCalls = 0;           // one per non-empty mesh
    double renderMs = 0.0;            // clear + draw + glFinish, wall clock
    double readbackMs = 0.0;          // glReadPixels + row flips (0 without readback)
};

struct GlTiming {
    int frames = 0;
    uint64_t trianglesPerFrame = 0;
    double medianMs = 0.0;  // render time per frame (clear + draw + glFinish)
    double minMs = 0.0;
    double maxMs = 0.0;
    double trianglesPerSecond = 0.0;  // trianglesPerFrame / median frame time
};

class GlRenderer {
public:
    // Opens EGL on the Mesa surfaceless platform and creates an OpenGL 4.5 core context.
    // Returns kUnsupported with the reason when EGL, the platform or GL 4.5 is unavailable, or
    // when config.threads differs from the thread count another live renderer started llvmpipe
    // with. Precondition: config.threads >= 0.
    static Result<std::unique_ptr<GlRenderer>> create(const GlConfig& config = {});
    ~GlRenderer();
    GlRenderer(const GlRenderer&) = delete;
    GlRenderer& operator=(const GlRenderer&) = delete;

    // Copies the scene's positions and indices into one static vertex and one static index
    // buffer (replacing any earlier upload) and keeps each mesh's draw range, material colour
    // and first global triangle. Fails on an empty, unfinalised or inconsistent scene.
    Status upload(const scene::Scene& scene);

    // Clears and draws the uploaded scene into an offscreen framebuffer of the camera's size,
    // waits with glFinish, then reads back the requested targets. Fails when nothing was
    // uploaded or the size exceeds the driver's limit.
    Result<GlFrameStats> render(const Camera& camera, const GlTargets& targets = {});

    // Renders one untimed warm-up frame, then `frames` timed frames without readback.
    // Precondition for success: 1 <= frames <= 100000 and a scene uploaded.
    Result<GlTiming> timeFrames(const Camera& camera, int frames);

    // GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    const std::string& rendererName() const;
    // GL_VERSION, e.g. "4.5 (Core Profile) Mesa 22.3.6".
    const std::string& versionString() const;
    // LP_NUM_THREADS as seen when EGL was initialised (0 = unset: llvmpipe's default).
    int threads() const;

private:
    struct Impl;
    explicit GlRenderer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

}  // namespace plx::gl
