// The GL function table and what every context shares (read-back, description).
#include "handsteady_render/context.hpp"
#include "handsteady_render/error.hpp"
#include "handsteady_render/gl_functions.hpp"

#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

namespace hs::render {

GlFunctions load_gl_functions(GlProcLoader loader) {
  GlFunctions f;
#define HS_RENDER_GL_LOAD(type, name)                                         \
  f.name = reinterpret_cast<type>(loader("gl" #name));                        \
  if (f.name == nullptr) {                                                    \
    throw RenderError("OpenGL function gl" #name " is missing in this context"); \
  }
  HS_RENDER_GL_FUNCTIONS(HS_RENDER_GL_LOAD)
#undef HS_RENDER_GL_LOAD
  return f;
}

namespace {
thread_local const GlContext* t_bound_last = nullptr;
}  // namespace

GlContext::GlContext(int width, int height) : width_(width), height_(height) {}

GlContext::~GlContext() { clear_bound_last(); }

bool GlContext::bound_last() const { return t_bound_last == this; }
void GlContext::set_bound_last() { t_bound_last = this; }
void GlContext::clear_bound_last() {
  if (t_bound_last == this) {
    t_bound_last = nullptr;
  }
}

void GlContext::load_functions(GlProcLoader loader) {
  gl_ = std::make_unique<GlFunctions>(load_gl_functions(loader));
}

void GlContext::finish() {
  make_current();
  gl_->Finish();
}

Image GlContext::read_pixels() {
  make_current();
  const GlFunctions& gl = *gl_;
  gl.Finish();
  Image img(width_, height_);
  std::vector<std::uint8_t> bottom_up(img.pixels.size());
  gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.ReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, bottom_up.data());
  if (const GLenum err = gl.GetError(); err != GL_NO_ERROR) {
    throw RenderError("glReadPixels failed with GL error " + std::to_string(err));
  }
  const size_t row = static_cast<size_t>(width_) * 4;
  for (int y = 0; y < height_; ++y) {
    std::memcpy(img.pixels.data() + static_cast<size_t>(y) * row,
                bottom_up.data() + static_cast<size_t>(height_ - 1 - y) * row, row);
  }
  return img;
}

std::string GlContext::description() {
  make_current();
  auto str = [this](GLenum name) {
    const GLubyte* s = gl_->GetString(name);
    return s != nullptr ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
  };
  return str(GL_RENDERER) + ", " + str(GL_VERSION);
}

bool display_available() {
  auto set = [](const char* name) {
    const char* v = std::getenv(name);
    return v != nullptr && *v != '\0';
  };
  return set("DISPLAY") || set("WAYLAND_DISPLAY");
}

}  // namespace hs::render
