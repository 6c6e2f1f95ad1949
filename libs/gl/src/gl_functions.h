#pragma once
// The OpenGL 4.5 core entry points the renderer uses, loaded through eglGetProcAddress into a
// table of function pointers (typedefs from <GL/glcorearb.h>). No loader library is needed:
// Mesa's EGL returns core and extension functions alike (EGL_KHR_get_all_proc_addresses).

#include <GL/glcorearb.h>

#include <plx/core/status.h>

namespace plx::gl {

// X-macro list: PLX_GL_FUNCTION(type, name). Keep alphabetical.
#define PLX_GL_FUNCTION_LIST(X)                                              \
    X(PFNGLATTACHSHADERPROC, glAttachShader)                                 \
    X(PFNGLBINDFRAMEBUFFERPROC, glBindFramebuffer)                           \
    X(PFNGLBINDVERTEXARRAYPROC, glBindVertexArray)                           \
    X(PFNGLCHECKNAMEDFRAMEBUFFERSTATUSPROC, glCheckNamedFramebufferStatus)   \
    X(PFNGLCLEARNAMEDFRAMEBUFFERFVPROC, glClearNamedFramebufferfv)           \
    X(PFNGLCLEARNAMEDFRAMEBUFFERUIVPROC, glClearNamedFramebufferuiv)         \
    X(PFNGLCOMPILESHADERPROC, glCompileShader)                               \
    X(PFNGLCREATEBUFFERSPROC, glCreateBuffers)                               \
    X(PFNGLCREATEFRAMEBUFFERSPROC, glCreateFramebuffers)                     \
    X(PFNGLCREATEPROGRAMPROC, glCreateProgram)                               \
    X(PFNGLCREATERENDERBUFFERSPROC, glCreateRenderbuffers)                   \
    X(PFNGLCREATESHADERPROC, glCreateShader)                                 \
    X(PFNGLCREATEVERTEXARRAYSPROC, glCreateVertexArrays)                     \
    X(PFNGLDELETEBUFFERSPROC, glDeleteBuffers)                               \
    X(PFNGLDELETEFRAMEBUFFERSPROC, glDeleteFramebuffers)                     \
    X(PFNGLDELETEPROGRAMPROC, glDeleteProgram)                               \
    X(PFNGLDELETERENDERBUFFERSPROC, glDeleteRenderbuffers)                   \
    X(PFNGLDELETESHADERPROC, glDeleteShader)                                 \
    X(PFNGLDELETEVERTEXARRAYSPROC, glDeleteVertexArrays)                     \
    X(PFNGLDEPTHFUNCPROC, glDepthFunc)                                       \
    X(PFNGLDISABLEPROC, glDisable)                                           \
    X(PFNGLDRAWELEMENTSBASEVERTEXPROC, glDrawElementsBaseVertex)             \
    X(PFNGLENABLEPROC, glEnable)                                             \
    X(PFNGLENABLEVERTEXARRAYATTRIBPROC, glEnableVertexArrayAttrib)           \
    X(PFNGLFINISHPROC, glFinish)                                             \
    X(PFNGLGETERRORPROC, glGetError)                                         \
    X(PFNGLGETINTEGERVPROC, glGetIntegerv)                                   \
    X(PFNGLGETPROGRAMINFOLOGPROC, glGetProgramInfoLog)                       \
    X(PFNGLGETPROGRAMIVPROC, glGetProgramiv)                                 \
    X(PFNGLGETSHADERINFOLOGPROC, glGetShaderInfoLog)                         \
    X(PFNGLGETSHADERIVPROC, glGetShaderiv)                                   \
    X(PFNGLGETSTRINGPROC, glGetString)                                       \
    X(PFNGLGETUNIFORMLOCATIONPROC, glGetUniformLocation)                     \
    X(PFNGLLINKPROGRAMPROC, glLinkProgram)                                   \
    X(PFNGLNAMEDBUFFERDATAPROC, glNamedBufferData)                           \
    X(PFNGLNAMEDFRAMEBUFFERDRAWBUFFERSPROC, glNamedFramebufferDrawBuffers)   \
    X(PFNGLNAMEDFRAMEBUFFERREADBUFFERPROC, glNamedFramebufferReadBuffer)     \
    X(PFNGLNAMEDFRAMEBUFFERRENDERBUFFERPROC, glNamedFramebufferRenderbuffer) \
    X(PFNGLNAMEDRENDERBUFFERSTORAGEPROC, glNamedRenderbufferStorage)         \
    X(PFNGLPIXELSTOREIPROC, glPixelStorei)                                   \
    X(PFNGLPROGRAMUNIFORM1FPROC, glProgramUniform1f)                         \
    X(PFNGLPROGRAMUNIFORM1UIPROC, glProgramUniform1ui)                       \
    X(PFNGLPROGRAMUNIFORM3FPROC, glProgramUniform3f)                         \
    X(PFNGLPROGRAMUNIFORM4FPROC, glProgramUniform4f)                         \
    X(PFNGLPROGRAMUNIFORMMATRIX4FVPROC, glProgramUniformMatrix4fv)           \
    X(PFNGLREADPIXELSPROC, glReadPixels)                                     \
    X(PFNGLSHADERSOURCEPROC, glShaderSource)                                 \
    X(PFNGLUSEPROGRAMPROC, glUseProgram)                                     \
    X(PFNGLVERTEXARRAYATTRIBBINDINGPROC, glVertexArrayAttribBinding)         \
    X(PFNGLVERTEXARRAYATTRIBFORMATPROC, glVertexArrayAttribFormat)           \
    X(PFNGLVERTEXARRAYELEMENTBUFFERPROC, glVertexArrayElementBuffer)         \
    X(PFNGLVERTEXARRAYVERTEXBUFFERPROC, glVertexArrayVertexBuffer)           \
    X(PFNGLVIEWPORTPROC, glViewport)

struct GlFunctions {
#define PLX_GL_DECLARE(type, name) type name = nullptr;
    PLX_GL_FUNCTION_LIST(PLX_GL_DECLARE)
#undef PLX_GL_DECLARE
};

// Fills every pointer of the table with eglGetProcAddress. Precondition: an EGL display is
// initialised (a context need not be current). Fails naming the first entry point not found.
Status loadGlFunctions(GlFunctions* gl);

}  // namespace plx::gl
