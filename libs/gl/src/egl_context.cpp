#include "egl_context.h"

#include <EGL/eglext.h>
#include <dlfcn.h>
#include <link.h>

#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <string_view>

#include <fmt/format.h>

namespace plx::gl {
namespace {

// EGL hands out one display per (platform, native display) pair, so eglInitialize and
// eglTerminate on it must be paired across all contexts of the process.
struct SharedDisplay {
    std::mutex mutex;
    EGLDisplay display = EGL_NO_DISPLAY;
    int users = 0;
    int threads = 0;  // LP_NUM_THREADS at initialisation
};

SharedDisplay& sharedDisplay() {
    static SharedDisplay shared;
    return shared;
}

std::string eglErrorText(const char* what) {
    return fmt::format("{} failed (EGL error 0x{:04x})", what, unsigned(eglGetError()));
}

bool hasExtension(const char* list, const char* name) {
    if (list == nullptr) return false;
    size_t length = std::strlen(name);
    for (const char* p = std::strstr(list, name); p != nullptr; p = std::strstr(p + 1, name)) {
        bool startOk = p == list || p[-1] == ' ';
        bool endOk = p[length] == ' ' || p[length] == '\0';
        if (startOk && endOk) return true;
    }
    return false;
}

int threadsFromEnvironment() {
    const char* value = std::getenv("LP_NUM_THREADS");
    if (value == nullptr) return 0;
    char* end = nullptr;
    long n = std::strtol(value, &end, 10);
    return (end != value && *end == '\0' && n > 0 && n < 1024) ? int(n) : 0;
}

// Keeps the Mesa DRI driver that eglInitialize loaded (any "*_dri.so") resident for the life of
// the process. eglTerminate would otherwise unload it while allocations it made from its own
// globals are still live; they then look leaked to LeakSanitizer, and a later eglInitialize
// would pay for loading and relocating the driver again.
void pinLoadedDriver() {
    dl_iterate_phdr(
        [](dl_phdr_info* info, size_t, void*) {
            const char* name = info->dlpi_name;
            size_t length = name == nullptr ? 0 : std::strlen(name);
            constexpr std::string_view kSuffix = "_dri.so";
            if (length > kSuffix.size() &&
                std::string_view(name + length - kSuffix.size()) == kSuffix) {
                // RTLD_NOLOAD only takes a reference to the copy already loaded.
                dlopen(name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
            }
            return 0;
        },
        nullptr);
}

// Opens and initialises the surfaceless display, or adds a user to the live one.
Result<EGLDisplay> acquireDisplay(int threads) {
    SharedDisplay& shared = sharedDisplay();
    std::lock_guard lock(shared.mutex);
    if (shared.users > 0) {
        if (threads > 0 && threads != shared.threads) {
            return errorStatus(ErrorCode::kUnsupported,
                               fmt::format("llvmpipe already runs with LP_NUM_THREADS={} in this "
                                           "process; cannot switch to {} while a renderer lives",
                                           shared.threads, threads));
        }
        ++shared.users;
        return shared.display;
    }
    const char* clientExtensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!hasExtension(clientExtensions, "EGL_MESA_platform_surfaceless")) {
        return errorStatus(ErrorCode::kUnsupported,
                           "EGL: the Mesa surfaceless platform is unavailable "
                           "(EGL_MESA_platform_surfaceless missing; is libegl-mesa0 installed?)");
    }
    auto getPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (getPlatformDisplay == nullptr) {
        return errorStatus(ErrorCode::kUnsupported, "EGL: eglGetPlatformDisplayEXT is missing");
    }
    // llvmpipe reads LP_NUM_THREADS when its screen is created, inside eglInitialize.
    if (threads > 0 && setenv("LP_NUM_THREADS", std::to_string(threads).c_str(), 1) != 0) {
        return errorStatus(ErrorCode::kInternal, "cannot set LP_NUM_THREADS");
    }
    EGLDisplay display =
        getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display == EGL_NO_DISPLAY) {
        return errorStatus(ErrorCode::kUnsupported, eglErrorText("eglGetPlatformDisplayEXT"));
    }
    EGLint major = 0, minor = 0;
    if (eglInitialize(display, &major, &minor) != EGL_TRUE) {
        return errorStatus(ErrorCode::kUnsupported, eglErrorText("eglInitialize (surfaceless)"));
    }
    pinLoadedDriver();
    shared.display = display;
    shared.users = 1;
    shared.threads = threadsFromEnvironment();
    return display;
}

void releaseDisplay() {
    SharedDisplay& shared = sharedDisplay();
    std::lock_guard lock(shared.mutex);
    if (shared.users > 0 && --shared.users == 0) {
        eglTerminate(shared.display);
        eglReleaseThread();
        shared.display = EGL_NO_DISPLAY;
    }
}

// A config is only needed where EGL_KHR_no_config_context is missing.
Result<EGLConfig> chooseConfig(EGLDisplay display) {
    if (hasExtension(eglQueryString(display, EGL_EXTENSIONS), "EGL_KHR_no_config_context")) {
        return EGLConfig(EGL_NO_CONFIG_KHR);
    }
    const EGLint attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                                 EGL_PBUFFER_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint count = 0;
    if (eglChooseConfig(display, attributes, &config, 1, &count) != EGL_TRUE || count < 1) {
        return errorStatus(ErrorCode::kUnsupported, "EGL: no config supports desktop OpenGL");
    }
    return config;
}

}  // namespace

Result<std::unique_ptr<EglContext>> EglContext::create(int threads) {
    PLX_CHECK(threads >= 0);
    auto display = acquireDisplay(threads);
    if (!display) return display.status();
    std::unique_ptr<EglContext> context(new EglContext);
    context->mDisplay = *display;  // released by the destructor from here on
    context->mThreads = sharedDisplay().threads;

    const char* extensions = eglQueryString(context->mDisplay, EGL_EXTENSIONS);
    if (!hasExtension(extensions, "EGL_KHR_surfaceless_context")) {
        return errorStatus(ErrorCode::kUnsupported, "EGL: EGL_KHR_surfaceless_context missing");
    }
    if (eglBindAPI(EGL_OPENGL_API) != EGL_TRUE) {
        return errorStatus(ErrorCode::kUnsupported, eglErrorText("eglBindAPI(EGL_OPENGL_API)"));
    }
    auto config = chooseConfig(context->mDisplay);
    if (!config) return config.status();
    const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                                 4,
                                 EGL_CONTEXT_MINOR_VERSION,
                                 5,
                                 EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                 EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                 EGL_NONE};
    context->mContext = eglCreateContext(context->mDisplay, *config, EGL_NO_CONTEXT, attributes);
    if (context->mContext == EGL_NO_CONTEXT) {
        return errorStatus(ErrorCode::kUnsupported,
                           eglErrorText("eglCreateContext (OpenGL 4.5 core)"));
    }
    PLX_RETURN_IF_ERROR(context->makeCurrent());
    return context;
}

EglContext::~EglContext() {
    if (mContext != EGL_NO_CONTEXT) {
        if (eglGetCurrentContext() == mContext) {
            eglMakeCurrent(mDisplay, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        }
        eglDestroyContext(mDisplay, mContext);
    }
    if (mDisplay != EGL_NO_DISPLAY) releaseDisplay();
}

Status EglContext::makeCurrent() {
    if (eglGetCurrentContext() == mContext) return Status::ok();
    if (eglMakeCurrent(mDisplay, EGL_NO_SURFACE, EGL_NO_SURFACE, mContext) != EGL_TRUE) {
        return errorStatus(ErrorCode::kInternal, eglErrorText("eglMakeCurrent (surfaceless)"));
    }
    return Status::ok();
}

}  // namespace plx::gl
