#include "gl_functions.h"

#include <EGL/egl.h>

#include <string>

namespace plx::gl {

Status loadGlFunctions(GlFunctions* gl) {
#define PLX_GL_LOAD(type, name)                                                             \
    gl->name = reinterpret_cast<type>(eglGetProcAddress(#name));                            \
    if (gl->name == nullptr) {                                                              \
        return errorStatus(ErrorCode::kUnsupported,                                         \
                           std::string("OpenGL entry point ") + #name + " is unavailable"); \
    }
    PLX_GL_FUNCTION_LIST(PLX_GL_LOAD)
#undef PLX_GL_LOAD
    return Status::ok();
}

}  // namespace plx::gl
