#include <plx/gl/gl_renderer.h>

#include <algorithm>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "egl_context.h"
#include "gl_functions.h"

namespace plx::gl {
namespace {

constexpr int kMaxTimedFrames = 100000;

// Vertex stage: world position to clip space; the world position goes on to the fragment stage,
// whose screen-space derivatives give the face normal.
constexpr const char* kVertexShader = R"(#version 450 core
layout(location = 0) in vec3 aWorldPos;
uniform mat4 uClipFromWorld;
out vec3 vWorldPos;
void main() {
    vWorldPos = aWorldPos;
    gl_Position = uClipFromWorld * vec4(aWorldPos, 1.0);
}
)";

// Fragment stage: flat Lambert + ambient in linear RGB, two-sided (|n . l|), encoded to sRGB
// (IEC 61966-2-1), and the polygon ID. The world position interpolates on the triangle's plane,
// so the cross product of its x and y derivatives is normal to the face in every fragment; a
// degenerate (edge-on) face gets ambient only. gl_PrimitiveID counts triangles from 0 within a
// draw call, which draws one whole mesh, so adding the mesh's first global triangle and 1 gives
// the ID of the Conventions block.
constexpr const char* kFragmentShader = R"(#version 450 core
in vec3 vWorldPos;
uniform vec3 uLightDir;
uniform float uAmbient;
uniform vec3 uBaseColor;
uniform uint uFirstTriangle;
layout(location = 0) out vec4 oColor;
layout(location = 1) out uint oId;
vec3 encodeSrgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 low = 12.92 * c;
    vec3 high = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
    return mix(high, low, lessThanEqual(c, vec3(0.0031308)));
}
void main() {
    vec3 faceDir = cross(dFdx(vWorldPos), dFdy(vWorldPos));
    float faceLength = length(faceDir);
    float lambert = faceLength > 0.0 ? abs(dot(faceDir, uLightDir)) / faceLength : 0.0;
    oColor = vec4(encodeSrgb(uBaseColor * (uAmbient + lambert)), 1.0);
    oId = uint(gl_PrimitiveID) + uFirstTriangle + 1u;
}
)";

struct DrawRange {
    GLsizei indexCount = 0;
    size_t indexOffsetBytes = 0;
    GLint baseVertex = 0;
    GLuint firstTriangle = 0;
    Vec3 baseColor{0.8f};
};

std::string glErrorText(GLenum error) {
    switch (error) {
        case GL_INVALID_ENUM:
            return "GL_INVALID_ENUM";
        case GL_INVALID_VALUE:
            return "GL_INVALID_VALUE";
        case GL_INVALID_OPERATION:
            return "GL_INVALID_OPERATION";
        case GL_INVALID_FRAMEBUFFER_OPERATION:
            return "GL_INVALID_FRAMEBUFFER_OPERATION";
        case GL_OUT_OF_MEMORY:
            return "GL_OUT_OF_MEMORY";
        default:
            return fmt::format("0x{:04x}", unsigned(error));
    }
}

template <class T>
void flipRowsInto(const std::vector<T>& bottomUp, int width, int height, Image<T>* image) {
    image->resize(width, height);
    for (int y = 0; y < height; ++y) {
        const T* source = bottomUp.data() + size_t(height - 1 - y) * size_t(width);
        std::copy(source, source + width, image->row(y));
    }
}

}  // namespace

struct GlRenderer::Impl {
    GlConfig config;
    std::unique_ptr<EglContext> context;
    GlFunctions gl;
    std::string rendererName;
    std::string versionString;
    GLint maxRenderbufferSize = 0;

    GLuint program = 0;
    GLint uClipFromWorld = -1, uLightDir = -1, uAmbient = -1, uBaseColor = -1, uFirstTriangle = -1;

    GLuint vertexArray = 0, vertexBuffer = 0, indexBuffer = 0;
    std::vector<DrawRange> draws;
    uint64_t triangleCount = 0;
    bool uploaded = false;

    GLuint framebuffer = 0, colorBuffer = 0, idBuffer = 0, depthBuffer = 0;
    int fbWidth = 0, fbHeight = 0;
    std::vector<Rgba8> colorScratch;
    std::vector<uint32_t> idScratch;
    std::vector<float> depthScratch;

    ~Impl();
    Status checkGl(const char* what);
    Result<GLuint> compileShader(GLenum stage, const char* source);
    Status buildProgram();
    Status ensureFramebuffer(int width, int height);
    void deleteFramebuffer();
    void deleteSceneBuffers();
    Status readback(const Camera& camera, const GlTargets& targets);
};

GlRenderer::Impl::~Impl() {
    if (!context || !context->makeCurrent()) return;
    deleteFramebuffer();
    deleteSceneBuffers();
    if (program != 0) gl.glDeleteProgram(program);
}

Status GlRenderer::Impl::checkGl(const char* what) {
    GLenum error = gl.glGetError();
    if (error == GL_NO_ERROR) return Status::ok();
    while (gl.glGetError() != GL_NO_ERROR) {
    }
    ErrorCode code = error == GL_OUT_OF_MEMORY ? ErrorCode::kOutOfRange : ErrorCode::kInternal;
    return errorStatus(code, fmt::format("OpenGL error {} in {}", glErrorText(error), what));
}

Result<GLuint> GlRenderer::Impl::compileShader(GLenum stage, const char* source) {
    GLuint shader = gl.glCreateShader(stage);
    gl.glShaderSource(shader, 1, &source, nullptr);
    gl.glCompileShader(shader);
    GLint ok = GL_FALSE;
    gl.glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok == GL_TRUE) return shader;
    char log[1024] = {};
    gl.glGetShaderInfoLog(shader, sizeof(log), nullptr, log);
    gl.glDeleteShader(shader);
    return errorStatus(ErrorCode::kInternal, fmt::format("GLSL compile error: {}", log));
}

Status GlRenderer::Impl::buildProgram() {
    auto vertex = compileShader(GL_VERTEX_SHADER, kVertexShader);
    if (!vertex) return vertex.status();
    auto fragment = compileShader(GL_FRAGMENT_SHADER, kFragmentShader);
    if (!fragment) {
        gl.glDeleteShader(*vertex);
        return fragment.status();
    }
    program = gl.glCreateProgram();
    gl.glAttachShader(program, *vertex);
    gl.glAttachShader(program, *fragment);
    gl.glLinkProgram(program);
    gl.glDeleteShader(*vertex);
    gl.glDeleteShader(*fragment);
    GLint ok = GL_FALSE;
    gl.glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok != GL_TRUE) {
        char log[1024] = {};
        gl.glGetProgramInfoLog(program, sizeof(log), nullptr, log);
        return errorStatus(ErrorCode::kInternal, fmt::format("GLSL link error: {}", log));
    }
    uClipFromWorld = gl.glGetUniformLocation(program, "uClipFromWorld");
    uLightDir = gl.glGetUniformLocation(program, "uLightDir");
    uAmbient = gl.glGetUniformLocation(program, "uAmbient");
    uBaseColor = gl.glGetUniformLocation(program, "uBaseColor");
    uFirstTriangle = gl.glGetUniformLocation(program, "uFirstTriangle");
    Vec3 lightDir = glm::normalize(config.lightDir);
    gl.glProgramUniform3f(program, uLightDir, lightDir.x, lightDir.y, lightDir.z);
    gl.glProgramUniform1f(program, uAmbient, config.ambient);
    return checkGl("shader program setup");
}

void GlRenderer::Impl::deleteFramebuffer() {
    if (framebuffer != 0) gl.glDeleteFramebuffers(1, &framebuffer);
    GLuint buffers[] = {colorBuffer, idBuffer, depthBuffer};
    if (colorBuffer != 0) gl.glDeleteRenderbuffers(3, buffers);
    framebuffer = colorBuffer = idBuffer = depthBuffer = 0;
    fbWidth = fbHeight = 0;
}

// RGBA8 colour, R32UI polygon ID and 32-bit float depth, reallocated when the size changes.
Status GlRenderer::Impl::ensureFramebuffer(int width, int height) {
    if (framebuffer != 0 && width == fbWidth && height == fbHeight) return Status::ok();
    if (width > maxRenderbufferSize || height > maxRenderbufferSize) {
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("image {}x{} exceeds the driver's {} pixel limit", width,
                                       height, maxRenderbufferSize));
    }
    deleteFramebuffer();
    gl.glCreateFramebuffers(1, &framebuffer);
    GLuint buffers[3] = {};
    gl.glCreateRenderbuffers(3, buffers);
    colorBuffer = buffers[0];
    idBuffer = buffers[1];
    depthBuffer = buffers[2];
    gl.glNamedRenderbufferStorage(colorBuffer, GL_RGBA8, width, height);
    gl.glNamedRenderbufferStorage(idBuffer, GL_R32UI, width, height);
    gl.glNamedRenderbufferStorage(depthBuffer, GL_DEPTH_COMPONENT32F, width, height);
    gl.glNamedFramebufferRenderbuffer(framebuffer, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                                      colorBuffer);
    gl.glNamedFramebufferRenderbuffer(framebuffer, GL_COLOR_ATTACHMENT1, GL_RENDERBUFFER, idBuffer);
    gl.glNamedFramebufferRenderbuffer(framebuffer, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER,
                                      depthBuffer);
    const GLenum drawBuffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    gl.glNamedFramebufferDrawBuffers(framebuffer, 2, drawBuffers);
    PLX_RETURN_IF_ERROR(checkGl("framebuffer allocation"));
    GLenum status = gl.glCheckNamedFramebufferStatus(framebuffer, GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        deleteFramebuffer();
        return errorStatus(ErrorCode::kUnsupported,
                           fmt::format("framebuffer incomplete (status 0x{:04x})", status));
    }
    fbWidth = width;
    fbHeight = height;
    return Status::ok();
}

void GlRenderer::Impl::deleteSceneBuffers() {
    if (vertexArray != 0) gl.glDeleteVertexArrays(1, &vertexArray);
    GLuint buffers[] = {vertexBuffer, indexBuffer};
    if (vertexBuffer != 0) gl.glDeleteBuffers(2, buffers);
    vertexArray = vertexBuffer = indexBuffer = 0;
    draws.clear();
    triangleCount = 0;
    uploaded = false;
}

// Reads the requested attachments and flips them to top-left row order. Depth: GL stores window
// z = (z_ndc + 1) / 2 with z_ndc = A + B / z_view, where A = clipFromView[2][2] and
// B = clipFromView[3][2] (glm's [column][row]) and w_clip = -z_view, so
// 1/w = (z_ndc + A) / B.
Status GlRenderer::Impl::readback(const Camera& camera, const GlTargets& targets) {
    int width = fbWidth, height = fbHeight;
    size_t pixels = size_t(width) * size_t(height);
    gl.glPixelStorei(GL_PACK_ALIGNMENT, 1);
    if (targets.color != nullptr) {
        colorScratch.resize(pixels);
        gl.glNamedFramebufferReadBuffer(framebuffer, GL_COLOR_ATTACHMENT0);
        gl.glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, colorScratch.data());
        flipRowsInto(colorScratch, width, height, targets.color);
    }
    if (targets.id != nullptr) {
        idScratch.resize(pixels);
        gl.glNamedFramebufferReadBuffer(framebuffer, GL_COLOR_ATTACHMENT1);
        gl.glReadPixels(0, 0, width, height, GL_RED_INTEGER, GL_UNSIGNED_INT, idScratch.data());
        flipRowsInto(idScratch, width, height, targets.id);
    }
    if (targets.depth != nullptr) {
        depthScratch.resize(pixels);
        gl.glReadPixels(0, 0, width, height, GL_DEPTH_COMPONENT, GL_FLOAT, depthScratch.data());
        const Mat4& clipFromView = camera.clipFromView();
        float a = clipFromView[2][2], b = clipFromView[3][2];
        for (float& d : depthScratch) {
            d = d >= 1.0f ? 0.0f : std::max(0.0f, (2.0f * d - 1.0f + a) / b);
        }
        flipRowsInto(depthScratch, width, height, targets.depth);
    }
    return checkGl("glReadPixels");
}

GlRenderer::GlRenderer(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
GlRenderer::~GlRenderer() = default;

Result<std::unique_ptr<GlRenderer>> GlRenderer::create(const GlConfig& config) {
    if (config.threads < 0 || config.threads > 1024) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("GL thread count {} outside [0, 1024]", config.threads));
    }
    if (!isFinite(config.lightDir) || glm::length(config.lightDir) <= 0.0f ||
        !std::isfinite(config.ambient)) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           "GL light direction must be finite and non-zero, ambient finite");
    }
    auto impl = std::make_unique<Impl>();
    impl->config = config;
    auto context = EglContext::create(config.threads);
    if (!context) return context.status();
    impl->context = std::move(context).value();
    PLX_RETURN_IF_ERROR(loadGlFunctions(&impl->gl));
    GlFunctions& gl = impl->gl;
    auto text = [&](GLenum name) {
        const GLubyte* s = gl.glGetString(name);
        return s == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(s));
    };
    impl->rendererName = text(GL_RENDERER);
    impl->versionString = text(GL_VERSION);
    GLint major = 0, minor = 0;
    gl.glGetIntegerv(GL_MAJOR_VERSION, &major);
    gl.glGetIntegerv(GL_MINOR_VERSION, &minor);
    if (major * 10 + minor < 45) {
        return errorStatus(ErrorCode::kUnsupported,
                           fmt::format("OpenGL 4.5 needed, driver gives {}", impl->versionString));
    }
    if (config.requireLlvmpipe && impl->rendererName.find("llvmpipe") == std::string::npos) {
        return errorStatus(ErrorCode::kUnsupported,
                           fmt::format("renderer is '{}', not llvmpipe", impl->rendererName));
    }
    gl.glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &impl->maxRenderbufferSize);
    PLX_RETURN_IF_ERROR(impl->buildProgram());
    return std::unique_ptr<GlRenderer>(new GlRenderer(std::move(impl)));
}

Status GlRenderer::upload(const scene::Scene& scene) {
    Impl& m = *mImpl;
    PLX_RETURN_IF_ERROR(m.context->makeCurrent());
    GlFunctions& gl = m.gl;
    m.deleteSceneBuffers();

    // Check what the GPU would otherwise read out of bounds, and that finalize() is current.
    size_t triangles = 0, vertices = 0;
    for (const scene::Mesh& mesh : scene.meshes) {
        if (mesh.indices.size() % 3 != 0) {
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("mesh '{}' has {} indices, not a multiple of 3",
                                           mesh.name, mesh.indices.size()));
        }
        for (uint32_t index : mesh.indices) {
            if (index >= mesh.positions.size()) {
                return errorStatus(ErrorCode::kInvalidArgument,
                                   fmt::format("mesh '{}' index {} out of range ({} vertices)",
                                               mesh.name, index, mesh.positions.size()));
            }
        }
        if (mesh.materialIndex < 0 || size_t(mesh.materialIndex) >= scene.materials.size()) {
            return errorStatus(
                ErrorCode::kInvalidArgument,
                fmt::format("mesh '{}' material {} out of range", mesh.name, mesh.materialIndex));
        }
        triangles += mesh.triangleCount();
        vertices += mesh.vertexCount();
    }
    if (triangles == 0) {
        return errorStatus(ErrorCode::kInvalidArgument, "scene has no triangles to upload");
    }
    if (triangles != scene.triangleCount()) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           "scene triangle offsets are stale: call Scene::finalize() first");
    }
    constexpr size_t kMaxCount = size_t(std::numeric_limits<GLint>::max()) / 12;
    if (triangles >= kMaxCount || vertices >= kMaxCount) {
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("scene too large for one GL buffer ({} triangles, {} "
                                       "vertices)",
                                       triangles, vertices));
    }

    // One merged vertex buffer (positions only: flat shading uses the face normal) and one
    // merged index buffer; each mesh keeps its local indices and draws with a base vertex.
    std::vector<Vec3> positions;
    std::vector<uint32_t> indices;
    positions.reserve(vertices);
    indices.reserve(triangles * 3);
    for (size_t meshIndex = 0; meshIndex < scene.meshes.size(); ++meshIndex) {
        const scene::Mesh& mesh = scene.meshes[meshIndex];
        if (mesh.triangleCount() > 0) {
            DrawRange draw;
            draw.indexCount = GLsizei(mesh.indices.size());
            draw.indexOffsetBytes = indices.size() * sizeof(uint32_t);
            draw.baseVertex = GLint(positions.size());
            draw.firstTriangle = GLuint(scene.firstTriangle(meshIndex));
            draw.baseColor = Vec3(scene.materials[size_t(mesh.materialIndex)].baseColor);
            m.draws.push_back(draw);
        }
        positions.insert(positions.end(), mesh.positions.begin(), mesh.positions.end());
        indices.insert(indices.end(), mesh.indices.begin(), mesh.indices.end());
    }

    GLuint buffers[2] = {};
    gl.glCreateBuffers(2, buffers);
    m.vertexBuffer = buffers[0];
    m.indexBuffer = buffers[1];
    gl.glNamedBufferData(m.vertexBuffer, GLsizeiptr(positions.size() * sizeof(Vec3)),
                         positions.data(), GL_STATIC_DRAW);
    gl.glNamedBufferData(m.indexBuffer, GLsizeiptr(indices.size() * sizeof(uint32_t)),
                         indices.data(), GL_STATIC_DRAW);
    gl.glCreateVertexArrays(1, &m.vertexArray);
    gl.glVertexArrayVertexBuffer(m.vertexArray, 0, m.vertexBuffer, 0, sizeof(Vec3));
    gl.glVertexArrayElementBuffer(m.vertexArray, m.indexBuffer);
    gl.glEnableVertexArrayAttrib(m.vertexArray, 0);
    gl.glVertexArrayAttribFormat(m.vertexArray, 0, 3, GL_FLOAT, GL_FALSE, 0);
    gl.glVertexArrayAttribBinding(m.vertexArray, 0, 0);
    Status status = m.checkGl("scene upload");
    if (!status) {
        m.deleteSceneBuffers();
        return status;
    }
    m.triangleCount = triangles;
    m.uploaded = true;
    return Status::ok();
}

Result<GlFrameStats> GlRenderer::render(const Camera& camera, const GlTargets& targets) {
    Impl& m = *mImpl;
    if (!m.uploaded) {
        return errorStatus(ErrorCode::kInvalidArgument, "GL render before a scene was uploaded");
    }
    PLX_RETURN_IF_ERROR(m.context->makeCurrent());
    GlFunctions& gl = m.gl;
    Stopwatch watch;
    PLX_RETURN_IF_ERROR(m.ensureFramebuffer(camera.width(), camera.height()));

    gl.glBindFramebuffer(GL_FRAMEBUFFER, m.framebuffer);
    gl.glViewport(0, 0, camera.width(), camera.height());
    gl.glEnable(GL_DEPTH_TEST);
    gl.glDepthFunc(GL_LESS);
    gl.glDisable(GL_CULL_FACE);
    const Rgba8 c = m.config.clearColor;
    const GLfloat clearColor[4] = {c.r / 255.0f, c.g / 255.0f, c.b / 255.0f, c.a / 255.0f};
    const GLuint clearId[4] = {0, 0, 0, 0};
    const GLfloat clearDepth = 1.0f;
    gl.glClearNamedFramebufferfv(m.framebuffer, GL_COLOR, 0, clearColor);
    gl.glClearNamedFramebufferuiv(m.framebuffer, GL_COLOR, 1, clearId);
    gl.glClearNamedFramebufferfv(m.framebuffer, GL_DEPTH, 0, &clearDepth);

    gl.glUseProgram(m.program);
    gl.glProgramUniformMatrix4fv(m.program, m.uClipFromWorld, 1, GL_FALSE,
                                 &camera.clipFromWorld()[0][0]);
    gl.glBindVertexArray(m.vertexArray);
    for (const DrawRange& draw : m.draws) {
        gl.glProgramUniform1ui(m.program, m.uFirstTriangle, draw.firstTriangle);
        gl.glProgramUniform3f(m.program, m.uBaseColor, draw.baseColor.r, draw.baseColor.g,
                              draw.baseColor.b);
        gl.glDrawElementsBaseVertex(GL_TRIANGLES, draw.indexCount, GL_UNSIGNED_INT,
                                    reinterpret_cast<const void*>(draw.indexOffsetBytes),
                                    draw.baseVertex);
    }
    gl.glFinish();
    GlFrameStats stats;
    stats.renderMs = watch.elapsedMs();
    stats.trianglesSubmitted = m.triangleCount;
    stats.drawCalls = uint32_t(m.draws.size());
    PLX_RETURN_IF_ERROR(m.checkGl("frame rendering"));

    if (targets.color != nullptr || targets.id != nullptr || targets.depth != nullptr) {
        watch.restart();
        PLX_RETURN_IF_ERROR(m.readback(camera, targets));
        stats.readbackMs = watch.elapsedMs();
    }
    return stats;
}

Result<GlTiming> GlRenderer::timeFrames(const Camera& camera, int frames) {
    if (frames < 1 || frames > kMaxTimedFrames) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("frame count {} outside [1, {}]", frames, kMaxTimedFrames));
    }
    auto warmUp = render(camera);
    if (!warmUp) return warmUp.status();
    std::vector<double> samples;
    samples.reserve(size_t(frames));
    for (int i = 0; i < frames; ++i) {
        auto stats = render(camera);
        if (!stats) return stats.status();
        samples.push_back(stats->renderMs);
    }
    GlTiming timing;
    timing.frames = frames;
    timing.trianglesPerFrame = mImpl->triangleCount;
    timing.medianMs = median(samples);
    timing.minMs = *std::min_element(samples.begin(), samples.end());
    timing.maxMs = *std::max_element(samples.begin(), samples.end());
    timing.trianglesPerSecond =
        timing.medianMs > 0.0 ? double(timing.trianglesPerFrame) / (timing.medianMs * 1e-3) : 0.0;
    return timing;
}

const std::string& GlRenderer::rendererName() const {
    return mImpl->rendererName;
}
const std::string& GlRenderer::versionString() const {
    return mImpl->versionString;
}
int GlRenderer::threads() const {
    return mImpl->context->threads();
}

}  // namespace plx::gl
