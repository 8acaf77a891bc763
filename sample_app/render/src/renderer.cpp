#include "handsteady_render/renderer.hpp"

#include "handsteady/skeleton.hpp"
#include "handsteady_render/embedded_shaders.hpp"
#include "handsteady_render/error.hpp"
#include "handsteady_render/font.hpp"
#include "handsteady_render/gl_functions.hpp"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>

namespace hs::render {

// One capsule: the segment p0-p1 of radius `radius` pixels (a disc when p0 == p1).
// Layout matches the attributes of shaders/stroke.vert.
struct Renderer::Stroke {
  glm::vec3 p0;
  glm::vec3 p1;
  glm::vec4 color;
  float radius;
};

struct Renderer::Gl {
  const GlFunctions* f = nullptr;
  GLuint stroke_program = 0, fill_program = 0;
  GLint stroke_mvp = -1, stroke_viewport = -1, fill_mvp = -1;
  GLuint stroke_vao = 0, stroke_vbo = 0, fill_vao = 0, fill_vbo = 0;
};

namespace {

struct FillVertex {
  glm::vec3 position;
  glm::vec4 color;
};

glm::vec4 vec(Color c) { return {c.r, c.g, c.b, c.a}; }

const void* attrib_offset(std::size_t bytes) { return reinterpret_cast<const void*>(bytes); }

GLuint compile(const GlFunctions& gl, GLenum type, std::string_view source, const char* name) {
  const GLuint shader = gl.CreateShader(type);
  const GLchar* text = source.data();
  const GLint length = static_cast<GLint>(source.size());
  gl.ShaderSource(shader, 1, &text, &length);
  gl.CompileShader(shader);
  GLint ok = GL_FALSE;
  gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint log_length = 0;
    gl.GetShaderiv(shader, GL_INFO_LOG_LENGTH, &log_length);
    std::string log(static_cast<size_t>(std::max(log_length, 1)), '\0');
    gl.GetShaderInfoLog(shader, log_length, nullptr, log.data());
    gl.DeleteShader(shader);
    throw RenderError(std::string("shader ") + name + " does not compile: " + log.c_str());
  }
  return shader;
}

GLuint link(const GlFunctions& gl, std::string_view vert, std::string_view frag, const char* name) {
  const GLuint vs = compile(gl, GL_VERTEX_SHADER, vert, name);
  GLuint fs = 0;
  try {
    fs = compile(gl, GL_FRAGMENT_SHADER, frag, name);
  } catch (...) {
    gl.DeleteShader(vs);
    throw;
  }
  const GLuint program = gl.CreateProgram();
  gl.AttachShader(program, vs);
  gl.AttachShader(program, fs);
  gl.LinkProgram(program);
  gl.DeleteShader(vs);
  gl.DeleteShader(fs);
  GLint ok = GL_FALSE;
  gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint log_length = 0;
    gl.GetProgramiv(program, GL_INFO_LOG_LENGTH, &log_length);
    std::string log(static_cast<size_t>(std::max(log_length, 1)), '\0');
    gl.GetProgramInfoLog(program, log_length, nullptr, log.data());
    gl.DeleteProgram(program);
    throw RenderError(std::string("shader program ") + name + " does not link: " + log.c_str());
  }
  return program;
}

bool finite(glm::vec3 p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

}  // namespace

Renderer::Renderer(GlContext& ctx, std::string font_name)
    : ctx_(ctx), gl_(std::make_unique<Gl>()), font_name_(std::move(font_name)) {
  ctx_.make_current();
  const GlFunctions& gl = ctx_.gl();
  gl_->f = &gl;
  try {
    gl_->stroke_program = link(gl, shaders::stroke_vert, shaders::stroke_frag, "stroke");
    gl_->fill_program = link(gl, shaders::fill_vert, shaders::fill_frag, "fill");
  } catch (...) {
    if (gl_->stroke_program != 0) {
      gl.DeleteProgram(gl_->stroke_program);
    }
    throw;
  }
  gl_->stroke_mvp = gl.GetUniformLocation(gl_->stroke_program, "u_mvp");
  gl_->stroke_viewport = gl.GetUniformLocation(gl_->stroke_program, "u_viewport");
  gl_->fill_mvp = gl.GetUniformLocation(gl_->fill_program, "u_mvp");

  // Capsules: per-instance attributes only; the vertex shader makes the 4 corners.
  gl.GenVertexArrays(1, &gl_->stroke_vao);
  gl.GenBuffers(1, &gl_->stroke_vbo);
  gl.BindVertexArray(gl_->stroke_vao);
  gl.BindBuffer(GL_ARRAY_BUFFER, gl_->stroke_vbo);
  const auto stride = static_cast<GLsizei>(sizeof(Stroke));
  const struct {
    GLuint index;
    GLint size;
    std::size_t offset;
  } stroke_attribs[] = {{0, 3, offsetof(Stroke, p0)},
                        {1, 3, offsetof(Stroke, p1)},
                        {2, 4, offsetof(Stroke, color)},
                        {3, 1, offsetof(Stroke, radius)}};
  for (const auto& a : stroke_attribs) {
    gl.EnableVertexAttribArray(a.index);
    gl.VertexAttribPointer(a.index, a.size, GL_FLOAT, GL_FALSE, stride, attrib_offset(a.offset));
    gl.VertexAttribDivisor(a.index, 1);
  }

  gl.GenVertexArrays(1, &gl_->fill_vao);
  gl.GenBuffers(1, &gl_->fill_vbo);
  gl.BindVertexArray(gl_->fill_vao);
  gl.BindBuffer(GL_ARRAY_BUFFER, gl_->fill_vbo);
  const auto fill_stride = static_cast<GLsizei>(sizeof(FillVertex));
  gl.EnableVertexAttribArray(0);
  gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, fill_stride, attrib_offset(offsetof(FillVertex, position)));
  gl.EnableVertexAttribArray(1);
  gl.VertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, fill_stride, attrib_offset(offsetof(FillVertex, color)));
  gl.BindVertexArray(0);

  if (const GLenum err = gl.GetError(); err != GL_NO_ERROR) {
    throw RenderError("setting up the renderer failed with GL error " + std::to_string(err));
  }
  viewport_ = full_frame();
  camera_ = Camera::facing_plane(viewport_.aspect());
}

Renderer::~Renderer() {
  try {
    ctx_.make_current();
  } catch (...) {
    return;  // the context is unusable; its objects go with it
  }
  const GlFunctions& gl = *gl_->f;
  gl.DeleteBuffers(1, &gl_->stroke_vbo);
  gl.DeleteBuffers(1, &gl_->fill_vbo);
  gl.DeleteVertexArrays(1, &gl_->stroke_vao);
  gl.DeleteVertexArrays(1, &gl_->fill_vao);
  gl.DeleteProgram(gl_->stroke_program);
  gl.DeleteProgram(gl_->fill_program);
}

void Renderer::begin_frame(Color clear) {
  ctx_.make_current();
  const GlFunctions& gl = *gl_->f;
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_SCISSOR_TEST);
  gl.Enable(GL_BLEND);
  gl.BlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  gl.Viewport(0, 0, width(), height());
  gl.ClearColor(clear.r, clear.g, clear.b, clear.a);
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
  set_viewport(full_frame());
}

void Renderer::set_viewport(const Viewport& vp) {
  if (vp.width < 1 || vp.height < 1 || vp.x < 0 || vp.y < 0 || vp.x + vp.width > width() ||
      vp.y + vp.height > height()) {
    throw std::invalid_argument("viewport " + std::to_string(vp.width) + "x" + std::to_string(vp.height) + " at (" +
                                std::to_string(vp.x) + ", " + std::to_string(vp.y) + ") is empty or outside the " +
                                std::to_string(width()) + "x" + std::to_string(height()) + " frame");
  }
  ctx_.make_current();
  const GlFunctions& gl = *gl_->f;
  const int gl_y = height() - vp.y - vp.height;  // GL windows count rows from the bottom
  gl.Viewport(vp.x, gl_y, vp.width, vp.height);
  gl.Scissor(vp.x, gl_y, vp.width, vp.height);
  gl.Enable(GL_SCISSOR_TEST);
  viewport_ = vp;
}

void Renderer::clear_viewport(Color color) {
  ctx_.make_current();
  const GlFunctions& gl = *gl_->f;
  gl.ClearColor(color.r, color.g, color.b, color.a);
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
}

glm::mat4 Renderer::overlay_matrix() const {
  return glm::ortho(0.0f, static_cast<float>(viewport_.width), static_cast<float>(viewport_.height), 0.0f, -1.0f,
                    1.0f);
}

void Renderer::draw_strokes(const std::vector<Stroke>& strokes, const glm::mat4& mvp) {
  if (strokes.empty()) {
    return;
  }
  ctx_.make_current();
  const GlFunctions& gl = *gl_->f;
  gl.UseProgram(gl_->stroke_program);
  gl.UniformMatrix4fv(gl_->stroke_mvp, 1, GL_FALSE, glm::value_ptr(mvp));
  gl.Uniform2f(gl_->stroke_viewport, static_cast<float>(viewport_.width), static_cast<float>(viewport_.height));
  gl.BindVertexArray(gl_->stroke_vao);
  gl.BindBuffer(GL_ARRAY_BUFFER, gl_->stroke_vbo);
  gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(strokes.size() * sizeof(Stroke)), strokes.data(),
                GL_STREAM_DRAW);
  gl.DrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, static_cast<GLsizei>(strokes.size()));
  gl.BindVertexArray(0);
}

void Renderer::draw_triangles(std::span<const glm::vec3> positions, Color color, const glm::mat4& mvp) {
  if (positions.empty()) {
    return;
  }
  std::vector<FillVertex> vertices;
  vertices.reserve(positions.size());
  for (const glm::vec3& p : positions) {
    vertices.push_back({p, vec(color)});
  }
  ctx_.make_current();
  const GlFunctions& gl = *gl_->f;
  gl.UseProgram(gl_->fill_program);
  gl.UniformMatrix4fv(gl_->fill_mvp, 1, GL_FALSE, glm::value_ptr(mvp));
  gl.BindVertexArray(gl_->fill_vao);
  gl.BindBuffer(GL_ARRAY_BUFFER, gl_->fill_vbo);
  gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(FillVertex)), vertices.data(),
                GL_STREAM_DRAW);
  gl.DrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(vertices.size()));
  gl.BindVertexArray(0);
}

void Renderer::line3d(glm::vec3 a, glm::vec3 b, Color color, float width_px) {
  draw_strokes({Stroke{a, b, vec(color), 0.5f * width_px}}, camera_.view_projection());
}

void Renderer::polyline3d(std::span<const glm::vec3> points, Color color, float width_px) {
  std::vector<Stroke> strokes;
  for (size_t i = 1; i < points.size(); ++i) {
    strokes.push_back({points[i - 1], points[i], vec(color), 0.5f * width_px});
  }
  draw_strokes(strokes, camera_.view_projection());
}

void Renderer::polylines3d(std::span<const std::vector<glm::vec3>> lines, std::span<const Color> colors,
                           float width_px) {
  if (colors.size() != 1 && colors.size() != lines.size()) {
    throw std::invalid_argument("polylines3d: " + std::to_string(colors.size()) + " colours for " +
                                std::to_string(lines.size()) + " polylines (need 1 or one each)");
  }
  std::vector<Stroke> strokes;
  for (size_t k = 0; k < lines.size(); ++k) {
    const glm::vec4 c = vec(colors[colors.size() == 1 ? 0 : k]);
    const auto& points = lines[k];
    for (size_t i = 1; i < points.size(); ++i) {
      strokes.push_back({points[i - 1], points[i], c, 0.5f * width_px});
    }
  }
  draw_strokes(strokes, camera_.view_projection());
}

void Renderer::points3d(std::span<const glm::vec3> points, Color color, float diameter_px) {
  std::vector<Stroke> strokes;
  for (const glm::vec3& p : points) {
    strokes.push_back({p, p, vec(color), 0.5f * diameter_px});
  }
  draw_strokes(strokes, camera_.view_projection());
}

void Renderer::fill_quad3d(glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d, Color color) {
  const glm::vec3 tris[] = {a, b, c, a, c, d};
  draw_triangles(tris, color, camera_.view_projection());
}

void Renderer::draw_hand(const hs::Pose& pose, const HandStyle& style) {
  const Skeleton& skeleton = xr_hand_skeleton();
  std::vector<glm::vec3> joints(static_cast<size_t>(kJointCount));
  std::vector<bool> tracked(static_cast<size_t>(kJointCount));
  for (int j = 0; j < kJointCount; ++j) {
    const glm::vec3 p(static_cast<float>(pose(j, 0)), static_cast<float>(pose(j, 1)), static_cast<float>(pose(j, 2)));
    joints[static_cast<size_t>(j)] = p;
    tracked[static_cast<size_t>(j)] = finite(p);
  }
  // Painter's algorithm: bones and joints back to front by eye-space depth (the eye looks
  // down -z, so a larger z is nearer). A joint sorts just in front of its own bones, so
  // it covers their ends.
  struct Item {
    float depth;
    Stroke stroke;
  };
  std::vector<Item> items;
  auto depth = [this](glm::vec3 p) { return (camera_.view * glm::vec4(p, 1.0f)).z; };
  std::vector<float> joint_depth(static_cast<size_t>(kJointCount), 0.0f);
  for (int j = 0; j < kJointCount; ++j) {
    joint_depth[static_cast<size_t>(j)] = depth(joints[static_cast<size_t>(j)]);
  }
  for (const auto& [a, b] : skeleton.bones) {
    const auto ia = static_cast<size_t>(a), ib = static_cast<size_t>(b);
    if (tracked[ia] && tracked[ib]) {
      const float d = depth(0.5f * (joints[ia] + joints[ib]));
      items.push_back({d, {joints[ia], joints[ib], vec(style.bone), 0.5f * style.bone_width_px}});
      joint_depth[ia] = std::max(joint_depth[ia], d);
      joint_depth[ib] = std::max(joint_depth[ib], d);
    }
  }
  for (int j = 0; j < kJointCount; ++j) {
    const auto i = static_cast<size_t>(j);
    if (!tracked[i]) {
      continue;
    }
    const bool hi = j == style.highlight_joint;
    items.push_back({joint_depth[i] + 1e-4f,
                     {joints[i], joints[i], vec(hi ? style.highlight : style.joint),
                      0.5f * (hi ? style.highlight_diameter_px : style.joint_diameter_px)}});
  }
  std::stable_sort(items.begin(), items.end(), [](const Item& l, const Item& r) { return l.depth < r.depth; });
  std::vector<Stroke> strokes;
  strokes.reserve(items.size());
  for (const Item& it : items) {
    strokes.push_back(it.stroke);
  }
  draw_strokes(strokes, camera_.view_projection());
}

void Renderer::fill_rect(float x, float y, float w, float h, Color color) {
  const glm::vec3 a(x, y, 0.0f), b(x + w, y, 0.0f), c(x + w, y + h, 0.0f), d(x, y + h, 0.0f);
  const glm::vec3 tris[] = {a, b, c, a, c, d};
  draw_triangles(tris, color, overlay_matrix());
}

void Renderer::stroke_rect(float x, float y, float w, float h, Color color, float width_px) {
  const glm::vec2 pts[] = {{x, y}, {x + w, y}, {x + w, y + h}, {x, y + h}, {x, y}};
  polyline2d(pts, color, width_px);
}

void Renderer::line2d(glm::vec2 a, glm::vec2 b, Color color, float width_px) {
  draw_strokes({Stroke{glm::vec3(a, 0.0f), glm::vec3(b, 0.0f), vec(color), 0.5f * width_px}}, overlay_matrix());
}

void Renderer::polyline2d(std::span<const glm::vec2> points, Color color, float width_px) {
  std::vector<Stroke> strokes;
  for (size_t i = 1; i < points.size(); ++i) {
    strokes.push_back({glm::vec3(points[i - 1], 0.0f), glm::vec3(points[i], 0.0f), vec(color), 0.5f * width_px});
  }
  draw_strokes(strokes, overlay_matrix());
}

void Renderer::disc2d(glm::vec2 center, float diameter_px, Color color) {
  const glm::vec3 c(center, 0.0f);
  draw_strokes({Stroke{c, c, vec(color), 0.5f * diameter_px}}, overlay_matrix());
}

const HersheyFont& Renderer::font() const {
  if (!font_) {
    font_ = std::make_unique<HersheyFont>(font_name_);
  }
  return *font_;
}

std::vector<std::vector<glm::vec2>> Renderer::text_strokes(std::string_view s, glm::vec2 pos, const TextStyle& style,
                                                           Box& box) const {
  const HersheyFont& f = font();
  const float cap = f.cap_height();
  const float scale = style.size_px / cap;
  const float advance = f.advance(s);
  const float ax = style.align == Align::Left ? 0.0f : style.align == Align::Center ? 0.5f * advance : advance;
  const float ay = style.valign == VAlign::Baseline ? 0.0f
                   : style.valign == VAlign::Top    ? cap
                   : style.valign == VAlign::Middle ? 0.5f * cap
                                                    : -cap / 3.0f;  // Hershey descenders: 7 of 21
  const float angle = glm::radians(style.angle_deg);
  const float c = std::cos(angle), sn = std::sin(angle);
  auto strokes = f.strokes(s);
  float x0 = std::numeric_limits<float>::max(), y0 = x0, x1 = -x0, y1 = -x0;
  for (auto& path : strokes) {
    for (glm::vec2& v : path) {
      const glm::vec2 l = (v - glm::vec2(ax, ay)) * scale;  // y up
      const glm::vec2 r(l.x * c - l.y * sn, l.x * sn + l.y * c);
      v = glm::vec2(pos.x + r.x, pos.y - r.y);  // overlay: y down
      x0 = std::min(x0, v.x);
      y0 = std::min(y0, v.y);
      x1 = std::max(x1, v.x);
      y1 = std::max(y1, v.y);
    }
  }
  if (x0 > x1) {
    box = {pos.x, pos.y, 0.0f, 0.0f};
  } else {
    const float margin = 0.5f * style.stroke_px + 1.0f;  // pen radius + anti-aliased edge
    box = {x0 - margin, y0 - margin, x1 - x0 + 2.0f * margin, y1 - y0 + 2.0f * margin};
  }
  return strokes;
}

Box Renderer::text(std::string_view s, glm::vec2 pos, const TextStyle& style) {
  Box box;
  const auto paths = text_strokes(s, pos, style, box);
  std::vector<Stroke> strokes;
  for (const auto& path : paths) {
    if (path.size() == 1) {
      strokes.push_back({glm::vec3(path[0], 0.0f), glm::vec3(path[0], 0.0f), vec(style.color), 0.5f * style.stroke_px});
    }
    for (size_t i = 1; i < path.size(); ++i) {
      strokes.push_back(
          {glm::vec3(path[i - 1], 0.0f), glm::vec3(path[i], 0.0f), vec(style.color), 0.5f * style.stroke_px});
    }
  }
  draw_strokes(strokes, overlay_matrix());
  return box;
}

Box Renderer::measure_text(std::string_view s, glm::vec2 pos, const TextStyle& style) const {
  Box box;
  text_strokes(s, pos, style, box);
  return box;
}

}  // namespace hs::render
