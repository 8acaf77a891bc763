#pragma once
// OpenGL 3.3 core contexts: offscreen through OSMesa (always available, deterministic
// llvmpipe rendering) or a GLFW window when a display exists.
#include "handsteady_render/image.hpp"

#include <memory>
#include <string>

namespace hs::render {

struct GlFunctions;  // handsteady_render/gl_functions.hpp

// A context's function loader (OSMesaGetProcAddress, glfwGetProcAddress).
using GlProc = void (*)();
using GlProcLoader = GlProc (*)(const char* name);

// A context with a default framebuffer of width() x height() pixels. Not copyable; use
// it from one thread at a time. Renderers made on it must be destroyed before it.
class GlContext {
 public:
  virtual ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  virtual bool is_window() const = 0;
  // Binds the context to the calling thread (Renderer::begin_frame does it).
  virtual void make_current() = 0;
  // Window: swaps buffers. Offscreen: waits for rendering to finish.
  virtual void present() = 0;
  // Window: processes window events. Offscreen: nothing.
  virtual void poll_events() {}
  // Window: the user closed it or pressed Escape. Offscreen: false.
  virtual bool should_close() const { return false; }
  // The framebuffer (a window's back buffer: call before present()), rows top-down.
  Image read_pixels();
  // "GL_RENDERER, GL_VERSION", e.g. "llvmpipe (LLVM 15.0.6, 256 bits), 4.5 (Core Profile)
  // Mesa 22.3.6" (OSMesa gives 3.3 core or a later core version).
  std::string description();
  // The GL functions of this context (valid while it is current).
  const GlFunctions& gl() const { return *gl_; }

 protected:
  GlContext(int width, int height);
  // Loads the function table; throws RenderError naming a missing function.
  void load_functions(GlProcLoader loader);
  // make_current() and glFinish.
  void finish();
  // Which hs_render context this thread bound last. OSMesa and Mesa's GLX share the
  // current-context state of libglapi, so a back end cannot trust its own "current"
  // query after the other one bound a context: it binds again unless it was the last.
  bool bound_last() const;
  void set_bound_last();
  void clear_bound_last();
  int width_;
  int height_;

 private:
  std::unique_ptr<GlFunctions> gl_;
};

// An offscreen OSMesa context (OpenGL 3.3 core). Throws std::invalid_argument unless
// 1 <= width, height <= kMaxImageSide, RenderError when Mesa cannot make one.
std::unique_ptr<GlContext> create_offscreen_context(int width, int height);

// True when DISPLAY or WAYLAND_DISPLAY is set (a window may be possible).
bool display_available();
// True when hs_render was built with GLFW.
bool window_support_built();
// A visible, non-resizable GLFW window with an OpenGL 3.3 core context; its framebuffer
// may be larger than width x height on high-DPI screens (see width(), height()).
// Returns nullptr, and the reason in *why_not when given, when there is no display,
// no GLFW, or GLFW or the context fail: the caller then falls back to
// create_offscreen_context. Throws std::invalid_argument for bad sizes.
std::unique_ptr<GlContext> create_window_context(int width, int height, const std::string& title,
                                                 std::string* why_not = nullptr);

}  // namespace hs::render
