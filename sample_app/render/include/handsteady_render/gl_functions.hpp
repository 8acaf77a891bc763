#pragma once
// The OpenGL 3.3 core functions hs_render calls, loaded explicitly through the context's
// proc-address function (OSMesaGetProcAddress, glfwGetProcAddress) into a table: an
// OSMesa-only process has no libGL to link prototypes from. gl.Clear(...) calls glClear.
#include "handsteady_render/context.hpp"

#include <GL/glcorearb.h>

namespace hs::render {

// X(type, name): glName has the pointer type `type`. Add a function here to use it.
#define HS_RENDER_GL_FUNCTIONS(X)                                   \
  X(PFNGLGETSTRINGPROC, GetString)                                  \
  X(PFNGLGETERRORPROC, GetError)                                    \
  X(PFNGLGETINTEGERVPROC, GetIntegerv)                              \
  X(PFNGLFINISHPROC, Finish)                                        \
  X(PFNGLENABLEPROC, Enable)                                        \
  X(PFNGLDISABLEPROC, Disable)                                      \
  X(PFNGLBLENDFUNCSEPARATEPROC, BlendFuncSeparate)                  \
  X(PFNGLVIEWPORTPROC, Viewport)                                    \
  X(PFNGLSCISSORPROC, Scissor)                                      \
  X(PFNGLCLEARCOLORPROC, ClearColor)                                \
  X(PFNGLCLEARPROC, Clear)                                          \
  X(PFNGLPIXELSTOREIPROC, PixelStorei)                              \
  X(PFNGLREADPIXELSPROC, ReadPixels)                                \
  X(PFNGLCREATESHADERPROC, CreateShader)                            \
  X(PFNGLSHADERSOURCEPROC, ShaderSource)                            \
  X(PFNGLCOMPILESHADERPROC, CompileShader)                          \
  X(PFNGLGETSHADERIVPROC, GetShaderiv)                              \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                    \
  X(PFNGLDELETESHADERPROC, DeleteShader)                            \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram)                          \
  X(PFNGLATTACHSHADERPROC, AttachShader)                            \
  X(PFNGLLINKPROGRAMPROC, LinkProgram)                              \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                            \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                  \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                          \
  X(PFNGLUSEPROGRAMPROC, UseProgram)                                \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                \
  X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                    \
  X(PFNGLUNIFORM2FPROC, Uniform2f)                                  \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                      \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                      \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                \
  X(PFNGLGENBUFFERSPROC, GenBuffers)                                \
  X(PFNGLBINDBUFFERPROC, BindBuffer)                                \
  X(PFNGLBUFFERDATAPROC, BufferData)                                \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                          \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)      \
  X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)              \
  X(PFNGLVERTEXATTRIBDIVISORPROC, VertexAttribDivisor)              \
  X(PFNGLDRAWARRAYSPROC, DrawArrays)                                \
  X(PFNGLDRAWARRAYSINSTANCEDPROC, DrawArraysInstanced)

struct GlFunctions {
#define HS_RENDER_GL_MEMBER(type, name) type name = nullptr;
  HS_RENDER_GL_FUNCTIONS(HS_RENDER_GL_MEMBER)
#undef HS_RENDER_GL_MEMBER
};

// Loads every function of the table through loader; throws RenderError naming the first
// one the context does not have.
GlFunctions load_gl_functions(GlProcLoader loader);

}  // namespace hs::render
