#pragma once
// An OpenGL 4.5 core context on EGL's Mesa surfaceless platform (EGL_MESA_platform_surfaceless):
// no window, no display server, rendering only into framebuffer objects.

#include <EGL/egl.h>

#include <memory>

#include <plx/core/status.h>

namespace plx::gl {

class EglContext {
public:
    // Initialises the process-wide surfaceless display (reference counted across contexts) and
    // creates a context on it. threads > 0 is exported as LP_NUM_THREADS before the display's
    // first initialisation; asking for a different count while the display is live fails, since
    // llvmpipe reads the variable only when the display is initialised.
    static Result<std::unique_ptr<EglContext>> create(int threads);
    ~EglContext();
    EglContext(const EglContext&) = delete;
    EglContext& operator=(const EglContext&) = delete;

    // Makes the context current on the calling thread (no surface) unless it already is.
    Status makeCurrent();
    // LP_NUM_THREADS when the display was initialised, 0 when unset or not a number.
    int threads() const { return mThreads; }

private:
    EglContext() = default;
    EGLDisplay mDisplay = EGL_NO_DISPLAY;
    EGLContext mContext = EGL_NO_CONTEXT;
    int mThreads = 0;
};

}  // namespace plx::gl
