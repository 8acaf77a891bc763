#pragma once
// hs_render's exception: OpenGL, font and file failures. Bad arguments (sizes, counts)
// throw std::invalid_argument instead.
#include <stdexcept>

namespace hs::render {

class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace hs::render
