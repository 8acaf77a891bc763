// Offscreen contexts through OSMesa (Mesa's llvmpipe): OpenGL 3.3 core into our buffer.
#include "handsteady_render/context.hpp"
#include "handsteady_render/error.hpp"

#include <GL/osmesa.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace hs::render {

namespace {

class OsMesaContext final : public GlContext {
 public:
  OsMesaContext(int width, int height) : GlContext(width, height) {
    const int attribs[] = {
        OSMESA_FORMAT, OSMESA_RGBA,                 //
        OSMESA_DEPTH_BITS, 24,                      //
        OSMESA_STENCIL_BITS, 8,                     //
        OSMESA_PROFILE, OSMESA_CORE_PROFILE,        //
        OSMESA_CONTEXT_MAJOR_VERSION, 3,            //
        OSMESA_CONTEXT_MINOR_VERSION, 3,            //
        0,
    };
    ctx_ = OSMesaCreateContextAttribs(attribs, nullptr);
    if (ctx_ == nullptr) {
      throw RenderError("OSMesa could not create an OpenGL 3.3 core context (Mesa with llvmpipe needed)");
    }
    buffer_.resize(static_cast<size_t>(width) * static_cast<size_t>(height) * 4);
    try {
      make_current();
      load_functions(&OSMesaGetProcAddress);
    } catch (...) {
      release();
      throw;
    }
  }
  ~OsMesaContext() override { release(); }

  bool is_window() const override { return false; }

  void make_current() override {
    if (bound_last() && OSMesaGetCurrentContext() == ctx_) {
      return;
    }
    if (OSMesaMakeCurrent(ctx_, buffer_.data(), GL_UNSIGNED_BYTE, width_, height_) == 0) {
      throw RenderError("OSMesaMakeCurrent failed for a " + std::to_string(width_) + "x" + std::to_string(height_) +
                        " buffer");
    }
    set_bound_last();
  }

  void present() override { finish(); }

 private:
  void release() {
    if (ctx_ == nullptr) {
      return;
    }
    if (OSMesaGetCurrentContext() == ctx_) {
      OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0);
    }
    clear_bound_last();
    OSMesaDestroyContext(ctx_);
    ctx_ = nullptr;
  }

  OSMesaContext ctx_ = nullptr;
  std::vector<std::uint8_t> buffer_;
};

}  // namespace

std::unique_ptr<GlContext> create_offscreen_context(int width, int height) {
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide) {
    throw std::invalid_argument("offscreen context: size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is not within 1.." + std::to_string(kMaxImageSide));
  }
  return std::make_unique<OsMesaContext>(width, height);
}

}  // namespace hs::render
