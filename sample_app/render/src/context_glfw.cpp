// Window contexts through GLFW (when hs_render was built with it): OpenGL 3.3 core.
#include "handsteady_render/context.hpp"
#include "handsteady_render/error.hpp"

#ifdef HS_RENDER_HAVE_GLFW
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#endif

#include <stdexcept>
#include <string>

namespace hs::render {

namespace {

#ifdef HS_RENDER_HAVE_GLFW
std::string& last_glfw_error() {
  static std::string message;
  return message;
}

void on_glfw_error(int code, const char* text) {
  last_glfw_error() = "GLFW error " + std::to_string(code) + ": " + (text != nullptr ? text : "?");
}

// glfwInit/glfwTerminate around the windows that are open.
int& glfw_windows() {
  static int count = 0;
  return count;
}

class GlfwContext final : public GlContext {
 public:
  // Takes ownership of window (one of glfw_windows()).
  GlfwContext(GLFWwindow* window, int fb_width, int fb_height) : GlContext(fb_width, fb_height), window_(window) {}
  ~GlfwContext() override {
    if (glfwGetCurrentContext() == window_) {
      glfwMakeContextCurrent(nullptr);
    }
    clear_bound_last();
    glfwDestroyWindow(window_);
    if (--glfw_windows() == 0) {
      glfwTerminate();
    }
  }

  void init() {
    make_current();
    glfwSwapInterval(1);
    load_functions(&glfwGetProcAddress);
  }

  bool is_window() const override { return true; }
  void make_current() override {
    const bool glfw_current = glfwGetCurrentContext() == window_;
    if (bound_last() && glfw_current) {
      return;
    }
    if (glfw_current) {
      glfwMakeContextCurrent(nullptr);  // GLX would skip binding the same context again
    }
    glfwMakeContextCurrent(window_);
    set_bound_last();
  }
  void present() override { glfwSwapBuffers(window_); }
  void poll_events() override {
    glfwPollEvents();
    if (glfwGetKey(window_, GLFW_KEY_ESCAPE) == GLFW_PRESS) {
      glfwSetWindowShouldClose(window_, GLFW_TRUE);
    }
  }
  bool should_close() const override { return glfwWindowShouldClose(window_) != 0; }

 private:
  GLFWwindow* window_;
};
#endif

}  // namespace

bool window_support_built() {
#ifdef HS_RENDER_HAVE_GLFW
  return true;
#else
  return false;
#endif
}

std::unique_ptr<GlContext> create_window_context(int width, int height, const std::string& title,
                                                 std::string* why_not) {
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide) {
    throw std::invalid_argument("window context: size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is not within 1.." + std::to_string(kMaxImageSide));
  }
  auto fail = [why_not](std::string why) -> std::unique_ptr<GlContext> {
    if (why_not != nullptr) {
      *why_not = std::move(why);
    }
    return nullptr;
  };
#ifdef HS_RENDER_HAVE_GLFW
  if (!display_available()) {
    return fail("no display (DISPLAY and WAYLAND_DISPLAY are unset)");
  }
  glfwSetErrorCallback(on_glfw_error);
  last_glfw_error().clear();
  if (glfw_windows() == 0 && glfwInit() != GLFW_TRUE) {
    return fail("glfwInit failed: " + last_glfw_error());
  }
  glfwDefaultWindowHints();
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
  GLFWwindow* window = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (window == nullptr) {
    if (glfw_windows() == 0) {
      glfwTerminate();
    }
    return fail("no OpenGL 3.3 core window: " + last_glfw_error());
  }
  ++glfw_windows();
  int fb_width = 0, fb_height = 0;
  glfwGetFramebufferSize(window, &fb_width, &fb_height);
  if (fb_width < 1 || fb_height < 1) {
    fb_width = width;
    fb_height = height;
  }
  auto ctx = std::make_unique<GlfwContext>(window, fb_width, fb_height);
  try {
    ctx->init();
  } catch (const RenderError& e) {
    return fail(e.what());
  }
  return ctx;
#else
  (void)title;
  return fail("hs_render was built without GLFW");
#endif
}

}  // namespace hs::render
