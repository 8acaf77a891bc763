// hs_render through OSMesa: known scenes give the expected pixels, PNG files, plots, errors.
#include "handsteady_render/camera.hpp"
#include "handsteady_render/context.hpp"
#include "handsteady_render/error.hpp"
#include "handsteady_render/font.hpp"
#include "handsteady_render/image.hpp"
#include "handsteady_render/plot.hpp"
#include "handsteady_render/renderer.hpp"
#include "test_support.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

using namespace hs::render;

namespace {

constexpr Rgba8 kBg{20, 30, 40, 255};
const Color kBgColor = Color::rgb8(20, 30, 40);

bool near(Rgba8 a, Rgba8 b, int tol = 2) {
  return std::abs(a.r - b.r) <= tol && std::abs(a.g - b.g) <= tol && std::abs(a.b - b.b) <= tol &&
         std::abs(a.a - b.a) <= tol;
}

// Pixels of img within tol of c.
int count(const Image& img, Rgba8 c, int tol = 2) {
  int n = 0;
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      n += near(img.at(x, y), c, tol) ? 1 : 0;
    }
  }
  return n;
}

// Centre of the pixels within tol of c (pixel (x, y) has its centre at x + 0.5, y + 0.5).
std::optional<glm::dvec2> centroid(const Image& img, Rgba8 c, int tol = 2) {
  glm::dvec2 sum(0.0);
  int n = 0;
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      if (near(img.at(x, y), c, tol)) {
        sum += glm::dvec2(x + 0.5, y + 0.5);
        ++n;
      }
    }
  }
  if (n == 0) {
    return std::nullopt;
  }
  return sum / static_cast<double>(n);
}

struct Scene {
  std::unique_ptr<GlContext> ctx;
  std::unique_ptr<Renderer> r;
  Scene(int w, int h) : ctx(create_offscreen_context(w, h)), r(std::make_unique<Renderer>(*ctx)) {
    r->begin_frame(kBgColor);
  }
  ~Scene() { r.reset(); }  // before the context
};

}  // namespace

TEST_CASE("offscreen context is OpenGL 3.3 core and clears to the colour") {
  Scene s(64, 48);
  const std::string desc = s.ctx->description();
  INFO(desc);
  // OSMesa gives at least the 3.3 core profile asked for (llvmpipe: 4.5).
  CHECK(desc.find("Core Profile") != std::string::npos);
  const auto comma = desc.rfind(", ");
  REQUIRE(comma != std::string::npos);
  CHECK(std::stod(desc.substr(comma + 2)) >= 3.3);
  CHECK_FALSE(s.ctx->is_window());
  CHECK_FALSE(s.ctx->should_close());
  const Image img = s.r->read_pixels();
  REQUIRE(img.width == 64);
  REQUIRE(img.height == 48);
  for (auto [x, y] : {std::pair{0, 0}, {63, 0}, {0, 47}, {63, 47}, {32, 24}}) {
    CHECK(img.at(x, y) == kBg);
  }
  CHECK(count(img, kBg, 0) == 64 * 48);
}

TEST_CASE("a thick horizontal overlay line covers exactly its rows, top-down") {
  Scene s(120, 100);
  const Color red{1.0f, 0.0f, 0.0f, 1.0f};
  // y = 30 (pixels from the top), 6 px wide: pixel centres 27.5 .. 32.5 are within 3 px.
  s.r->line2d({10.0f, 30.0f}, {110.0f, 30.0f}, red, 6.0f);
  const Image img = s.r->read_pixels();
  const Rgba8 r8{255, 0, 0, 255};
  for (int y = 0; y < 100; ++y) {
    const bool inside = y >= 27 && y <= 32;
    CAPTURE(y);
    CHECK(near(img.at(60, y), inside ? r8 : kBg));
  }
  // Round caps: the line ends 3 px beyond its end points, nothing further.
  CHECK(near(img.at(8, 30), r8));
  CHECK(near(img.at(111, 30), r8));
  CHECK(near(img.at(5, 30), kBg));
  CHECK(near(img.at(114, 30), kBg));
  // Only those rows changed anywhere.
  for (int y = 0; y < 100; ++y) {
    for (int x = 0; x < 120; ++x) {
      if (y < 26 || y > 33) {
        REQUIRE(img.at(x, y) == kBg);
      }
    }
  }
}

TEST_CASE("a joint disc lands where the camera matrices project it") {
  const int w = 160, h = 120;
  Scene s(w, h);
  const Camera cam = Camera::facing_plane(static_cast<float>(w) / static_cast<float>(h));
  s.r->set_camera(cam);
  const glm::vec3 p(0.03f, -0.02f, -0.40f);
  s.r->points3d(std::span<const glm::vec3>(&p, 1), Color{0.0f, 1.0f, 0.0f, 1.0f}, 12.0f);
  const Image img = s.r->read_pixels();

  // Independently: clip = P V p, NDC, window pixels with y flipped for top-down rows.
  const glm::vec4 clip = cam.projection * cam.view * glm::vec4(p, 1.0f);
  const double ndc_x = static_cast<double>(clip.x) / static_cast<double>(clip.w);
  const double ndc_y = static_cast<double>(clip.y) / static_cast<double>(clip.w);
  const double ex = (ndc_x * 0.5 + 0.5) * w;
  const double ey = (1.0 - (ndc_y * 0.5 + 0.5)) * h;
  const auto c = centroid(img, {0, 255, 0, 255});
  REQUIRE(c.has_value());
  CHECK(std::abs(c->x - ex) < 0.25);
  CHECK(std::abs(c->y - ey) < 0.25);
  // A 12 px disc: about pi 6^2 fully covered pixels.
  const int n = count(img, {0, 255, 0, 255});
  CHECK(n > 90);
  CHECK(n < 125);
  // The camera's own projection agrees.
  const auto proj = cam.project(p, s.r->full_frame());
  REQUIRE(proj.has_value());
  CHECK(std::abs(static_cast<double>(proj->x) - ex) < 1e-3);
  CHECK(std::abs(static_cast<double>(proj->y) - ey) < 1e-3);
  // The default camera: the eye at the origin, looking down -Z, +Y up.
  const auto centre = cam.project({0.0f, 0.0f, -kWritingPlaneDistance}, s.r->full_frame());
  REQUIRE(centre.has_value());
  CHECK(std::abs(static_cast<double>(centre->x) - w / 2.0) < 1e-3);
  CHECK(std::abs(static_cast<double>(centre->y) - h / 2.0) < 1e-3);
  const auto above = cam.project({0.0f, 0.1f, -kWritingPlaneDistance}, s.r->full_frame());
  REQUIRE(above.has_value());
  CHECK(static_cast<double>(above->y) < h / 2.0);
  CHECK_FALSE(cam.project({0.0f, 0.0f, 0.3f}, s.r->full_frame()).has_value());  // behind the eye
}

TEST_CASE("two panels land in their viewports") {
  Scene s(200, 100);
  const auto panels = panel_row(200, 100, 2, 10);
  REQUIRE(panels.size() == 2);
  CHECK(panels[0] == Viewport{10, 10, 85, 80});
  CHECK(panels[1] == Viewport{105, 10, 85, 80});
  const Color colours[2] = {Color{0.0f, 0.0f, 1.0f, 1.0f}, Color{1.0f, 1.0f, 0.0f, 1.0f}};
  for (int i = 0; i < 2; ++i) {
    s.r->set_viewport(panels[static_cast<size_t>(i)]);
    s.r->clear_viewport(colours[i]);
    // A white disc at the panel centre, in panel coordinates.
    s.r->disc2d({42.5f, 40.0f}, 10.0f, Color{1.0f, 1.0f, 1.0f, 1.0f});
    // A line far beyond the panel is clipped to it.
    s.r->line2d({-500.0f, 5.0f}, {500.0f, 5.0f}, Color{1.0f, 0.0f, 1.0f, 1.0f}, 4.0f);
  }
  const Image img = s.r->read_pixels();
  for (int i = 0; i < 2; ++i) {
    const Viewport& vp = panels[static_cast<size_t>(i)];
    const Rgba8 c = colours[i].to_rgba8();
    CHECK(img.at(vp.x + 2, vp.y + 40) == c);
    CHECK(img.at(vp.x + vp.width - 1, vp.y + vp.height - 1) == c);
    CHECK(near(img.at(vp.x + 42, vp.y + 40), {255, 255, 255, 255}));
    CHECK(near(img.at(vp.x + 5, vp.y + 5), {255, 0, 255, 255}));
  }
  // Gaps and borders keep the background, the clipped lines included.
  for (int x = 0; x < 200; ++x) {
    if (!panels[0].contains(x, 15) && !panels[1].contains(x, 15)) {
      REQUIRE(img.at(x, 15) == kBg);
    }
  }
  for (int y = 0; y < 100; ++y) {
    REQUIRE(img.at(5, y) == kBg);
    REQUIRE(img.at(100, y) == kBg);
    REQUIRE(img.at(195, y) == kBg);
  }
  CHECK(img.at(50, 3) == kBg);
  CHECK(img.at(50, 95) == kBg);
  CHECK_THROWS_AS(s.r->set_viewport({150, 0, 100, 50}), std::invalid_argument);
  CHECK_THROWS_AS(s.r->set_viewport({0, 0, 0, 50}), std::invalid_argument);
}

TEST_CASE("text draws inside its box and nowhere else") {
  Scene s(240, 120);
  TextStyle style;
  style.size_px = 20.0f;
  style.color = Color{1.0f, 1.0f, 1.0f, 1.0f};
  style.stroke_px = 2.0f;
  const Box measured = s.r->measure_text("Hg 42 xy", {20.0f, 60.0f}, style);
  const Box box = s.r->text("Hg 42 xy", {20.0f, 60.0f}, style);
  CHECK(box.x == measured.x);
  CHECK(box.width == measured.width);
  // Capitals reach ~20 px above the baseline, descenders ~7 px below.
  CHECK(box.y < 60.0f - 19.0f);
  CHECK(box.y > 60.0f - 24.0f);
  CHECK(box.y + box.height > 60.0f + 5.0f);
  CHECK(box.y + box.height < 60.0f + 10.0f);
  TextStyle rotated = style;
  rotated.angle_deg = 90.0f;
  rotated.valign = VAlign::Middle;
  const Box box2 = s.r->text("x (mm) -0.5", {215.0f, 60.0f}, rotated);
  CHECK(box2.x + box2.width < 240.0f);
  CHECK(box2.x > box.x + box.width);
  const Image img = s.r->read_pixels();
  int inside = 0, outside = 0;
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      if (img.at(x, y) == kBg) {
        continue;
      }
      const float cx = static_cast<float>(x) + 0.5f, cy = static_cast<float>(y) + 0.5f;
      (box.contains(cx, cy) || box2.contains(cx, cy) ? inside : outside) += 1;
    }
  }
  CHECK(inside > 200);
  CHECK(outside == 0);

  // Alignment: centred text is centred on its anchor, rotated text is tall.
  style.align = Align::Center;
  style.valign = VAlign::Middle;
  const Box c = s.r->measure_text("HHHH", {120.0f, 60.0f}, style);
  CHECK(std::abs(c.x + 0.5f * c.width - 120.0f) < 2.5f);
  CHECK(std::abs(c.y + 0.5f * c.height - 60.0f) < 1.0f);
  style.angle_deg = 90.0f;
  const Box v = s.r->measure_text("HHHH", {120.0f, 60.0f}, style);
  CHECK(v.height > 2.0f * v.width);
  CHECK(std::abs(v.y + 0.5f * v.height - 60.0f) < 2.5f);
}

TEST_CASE("Hershey font: glyphs, advance and unknown characters") {
  const HersheyFont f("rowmans");
  CHECK(f.cap_height() == doctest::Approx(21.0));
  CHECK(f.advance("H") == doctest::Approx(22.0));
  CHECK(f.advance("HH") == doctest::Approx(44.0));
  CHECK(f.strokes("H").size() == 3);
  CHECK(f.strokes(" ").empty());
  CHECK(f.advance("\xb5") == doctest::Approx(f.advance("?")));  // non-ASCII byte: '?'
  CHECK_THROWS_AS(HersheyFont("no_such_font_xyz"), RenderError);
}

TEST_CASE("draw_hand draws tracked joints and skips untracked ones") {
  const int w = 200, h = 200;
  HandStyle style;
  style.bone = Color{0.0f, 0.0f, 1.0f, 1.0f};
  style.joint = Color{0.0f, 1.0f, 0.0f, 1.0f};
  style.highlight = Color{1.0f, 0.0f, 0.0f, 1.0f};
  const Camera cam = Camera::facing_plane(1.0f);
  hs::Pose pose = hs::test::synthetic_hand();
  for (int j = 0; j < hs::kJointCount; ++j) {
    pose(j, 1) -= 0.09;  // centred on the view
    pose(j, 2) -= 0.40;  // 0.40 m in front of the eye
  }
  const int tip = hs::idx(hs::Joint::IndexTip);
  std::vector<glm::vec3> joints;
  for (int j = 0; j < hs::kJointCount; ++j) {
    joints.emplace_back(static_cast<float>(pose(j, 0)), static_cast<float>(pose(j, 1)),
                        static_cast<float>(pose(j, 2)));
  }
  {
    Scene s(w, h);
    s.r->set_camera(cam);
    s.r->draw_hand(pose, style);
    const Image img = s.r->read_pixels();
    CHECK(count(img, {0, 0, 255, 255}) > 100);  // bones
    CHECK(count(img, {0, 255, 0, 255}) > 200);  // joints
    const auto red = centroid(img, {255, 0, 0, 255});
    REQUIRE(red.has_value());
    const auto expected = cam.project(joints[static_cast<size_t>(tip)], s.r->full_frame());
    REQUIRE(expected.has_value());
    CHECK(std::abs(red->x - static_cast<double>(expected->x)) < 0.5);
    CHECK(std::abs(red->y - static_cast<double>(expected->y)) < 0.5);
    // The wrist disc is drawn over the bones that meet there.
    const auto wrist = cam.project(joints[static_cast<size_t>(hs::idx(hs::Joint::Wrist))], s.r->full_frame());
    REQUIRE(wrist.has_value());
    CHECK(near(img.at(static_cast<int>(wrist->x), static_cast<int>(wrist->y)), {0, 255, 0, 255}));
  }
  {
    // Untracked except the index tip and the palm: no bones, two discs.
    hs::Pose partial = hs::untracked_pose();
    partial.row(tip) = pose.row(tip);
    partial.row(hs::idx(hs::Joint::Palm)) = pose.row(hs::idx(hs::Joint::Palm));
    Scene s(w, h);
    s.r->set_camera(cam);
    s.r->draw_hand(partial, style);
    const Image img = s.r->read_pixels();
    CHECK(count(img, {0, 0, 255, 255}, 60) == 0);
    CHECK(count(img, {0, 255, 0, 255}) > 30);
    CHECK(count(img, {255, 0, 0, 255}) > 60);
    // Fully untracked: nothing at all.
    s.r->begin_frame(kBgColor);
    s.r->draw_hand(hs::untracked_pose(), style);
    CHECK(count(s.r->read_pixels(), kBg, 0) == w * h);
  }
}

TEST_CASE("3D polylines, filled quads and painter's order") {
  const int w = 160, h = 120;
  Scene s(w, h);
  const Camera cam = Camera::facing_plane(static_cast<float>(w) / static_cast<float>(h));
  s.r->set_camera(cam);
  const float z = -kWritingPlaneDistance;
  // The plane's quad fills the middle, an ink stroke on top.
  s.r->fill_quad3d({-0.1f, -0.1f, z}, {0.1f, -0.1f, z}, {0.1f, 0.1f, z}, {-0.1f, 0.1f, z},
                   Color{1.0f, 1.0f, 1.0f, 1.0f});
  const std::vector<glm::vec3> ink = {{-0.05f, 0.0f, z}, {0.0f, 0.03f, z}, {0.05f, 0.0f, z}};
  s.r->polyline3d(ink, Color{0.0f, 0.0f, 0.0f, 1.0f}, 3.0f);
  // Two more strokes with their own colours in one call.
  const std::vector<std::vector<glm::vec3>> strokes = {{{-0.05f, -0.05f, z}, {-0.02f, -0.05f, z}},
                                                       {{0.02f, -0.05f, z}, {0.05f, -0.05f, z}}};
  const Color two[] = {Color{1.0f, 0.0f, 0.0f, 1.0f}, Color{0.0f, 0.0f, 1.0f, 1.0f}};
  s.r->polylines3d(strokes, two, 4.0f);
  CHECK_THROWS_AS(s.r->polylines3d(strokes, std::span<const Color>(), 4.0f), std::invalid_argument);
  const Image img = s.r->read_pixels();
  const auto left = cam.project({-0.035f, -0.05f, z}, s.r->full_frame());
  const auto right = cam.project({0.035f, -0.05f, z}, s.r->full_frame());
  REQUIRE(left.has_value());
  REQUIRE(right.has_value());
  CHECK(near(img.at(static_cast<int>(left->x), static_cast<int>(left->y)), {255, 0, 0, 255}));
  CHECK(near(img.at(static_cast<int>(right->x), static_cast<int>(right->y)), {0, 0, 255, 255}));
  const auto a = cam.project({-0.09f, -0.09f, z}, s.r->full_frame());
  const auto b = cam.project({-0.11f, -0.11f, z}, s.r->full_frame());
  REQUIRE(a.has_value());
  REQUIRE(b.has_value());
  CHECK(img.at(static_cast<int>(a->x), static_cast<int>(a->y)) == Rgba8{255, 255, 255, 255});
  CHECK(img.at(static_cast<int>(b->x), static_cast<int>(b->y)) == kBg);
  for (const glm::vec3& p : ink) {
    const auto q = cam.project(p, s.r->full_frame());
    REQUIRE(q.has_value());
    CHECK(near(img.at(static_cast<int>(q->x), static_cast<int>(q->y)), {0, 0, 0, 255}));
  }
}

TEST_CASE("rendering is deterministic") {
  auto render = [] {
    Scene s(96, 64);
    s.r->set_camera(Camera::facing_plane(1.5f));
    hs::Pose pose = hs::test::synthetic_hand();
    for (int j = 0; j < hs::kJointCount; ++j) {
      pose(j, 2) -= 0.4;
    }
    s.r->draw_hand(pose);
    s.r->text("raw 123", {4.0f, 12.0f}, {});
    return s.r->read_pixels();
  };
  const Image a = render();
  const Image b = render();
  CHECK(a == b);
  CHECK(count(a, kBg, 0) < 96 * 64);
}

TEST_CASE("an offscreen plot between frames leaves the app's context alone") {
  auto draw = [](Renderer& r) {
    r.begin_frame(kBgColor);
    r.line2d({5.0f, 20.0f}, {90.0f, 40.0f}, Color{1.0f, 1.0f, 0.0f, 1.0f}, 5.0f);
    r.text("ok", {10.0f, 55.0f}, {});
    return r.read_pixels();
  };
  Scene s(100, 64);
  const Image before = draw(*s.r);
  TrajectoryPlot plot;
  plot.width = 320;
  plot.height = 240;
  const Image p = render_trajectory_plot(plot);
  CHECK(p.width == 320);
  const Image after = draw(*s.r);
  CHECK(after == before);
}

TEST_CASE("a window context renders like the offscreen one (needs a display)") {
  if (!display_available() || !window_support_built()) {
    MESSAGE("no display or no GLFW: window test skipped");
    return;
  }
#if defined(__SANITIZE_ADDRESS__)
  // glfwTerminate unloads Mesa's GLX driver, whose own leaks LeakSanitizer then reports
  // from an unknown module (no suppression can name it).
  MESSAGE("AddressSanitizer build: window test skipped");
  return;
#endif
  std::string why;
  auto win = create_window_context(160, 120, "test_render", &why);
  if (!win) {
    MESSAGE("no window (" << why << "): window test skipped");
    return;
  }
  CHECK(win->is_window());
  Image img;
  {
    Renderer r(*win);
    r.begin_frame(kBgColor);
    r.line2d({10.0f, 30.0f}, {150.0f, 30.0f}, Color{1.0f, 0.0f, 0.0f, 1.0f}, 6.0f);
    img = r.read_pixels();
    win->present();
    win->poll_events();
  }
  REQUIRE(img.width == win->width());
  CHECK(img.at(2, 2) == kBg);
  CHECK(near(img.at(60 * win->width() / 160, 30 * win->height() / 120), {255, 0, 0, 255}));
}

TEST_CASE("PNG round trip and composition") {
  const auto dir = hs::test::temp_dir("render_png");
  Image img(7, 5, {1, 2, 3, 255});
  img.set(0, 0, {255, 0, 0, 255});
  img.set(6, 4, {0, 0, 255, 128});
  img.set(3, 2, {10, 200, 30, 0});
  write_png(dir / "a.png", img);
  const Image back = read_png(dir / "a.png");
  CHECK(back == img);

  const Image other(3, 9, {9, 9, 9, 255});
  const Image images[] = {img, other};
  const Image row = compose_row(images, 2, {0, 0, 0, 0});
  CHECK(row.width == 7 + 2 + 3);
  CHECK(row.height == 9);
  CHECK(row.at(0, 0) == Rgba8{255, 0, 0, 255});
  CHECK(row.at(8, 0) == Rgba8{0, 0, 0, 0});   // gap
  CHECK(row.at(3, 7) == Rgba8{0, 0, 0, 0});   // below the shorter image
  CHECK(row.at(9, 8) == Rgba8{9, 9, 9, 255});
  const Image grid = compose_grid(images, 1, 1);
  CHECK(grid.width == 7);
  CHECK(grid.height == 9 + 1 + 9);
  CHECK(grid.at(0, 10) == Rgba8{9, 9, 9, 255});

  // A rendered frame survives the round trip.
  Scene s(50, 40);
  s.r->line2d({5.0f, 5.0f}, {45.0f, 35.0f}, Color{1.0f, 0.5f, 0.0f, 1.0f}, 3.0f);
  const Image frame = s.r->read_pixels();
  write_png(dir / "frame.png", frame);
  CHECK(read_png(dir / "frame.png") == frame);
  std::filesystem::remove_all(dir);
}

TEST_CASE("the trajectory plot writes a PNG of the requested size with its series colours") {
  const auto dir = hs::test::temp_dir("render_plot");
  TrajectoryPlot plot;
  plot.title = "Index fingertip, tracker preset";
  plot.width = 900;
  plot.height = 640;
  const Color truth = Color::rgb8(0, 0, 0), noisy = Color::rgb8(230, 40, 40), denoised = Color::rgb8(20, 90, 230);
  PlotSeries a{"truth", truth, {}, {}, 2.0f}, b{"noisy", noisy, {}, {}, 1.5f}, c{"denoised", denoised, {}, {}, 2.5f};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < 300; ++i) {
    const double t = i / 90.0;
    const glm::dvec3 p(0.05 * std::sin(2.0 * t), 0.03 * std::cos(3.0 * t), -0.4 + 0.01 * t);
    const glm::dvec3 off(0.004 * std::sin(37.0 * t), 0.004 * std::cos(41.0 * t), 0.003 * std::sin(53.0 * t));
    a.t.push_back(t);
    a.xyz.push_back(p);
    b.t.push_back(t);
    b.xyz.push_back(i >= 100 && i < 120 ? glm::dvec3(nan) : p + off + glm::dvec3(0.0, 0.0, 0.02));
    c.t.push_back(t);
    c.xyz.push_back(p + 0.2 * off - glm::dvec3(0.01, 0.01, 0.02));
  }
  plot.series = {a, b, c};
  write_trajectory_plot(dir / "plot.png", plot);
  const Image img = read_png(dir / "plot.png");
  CHECK(img.width == 900);
  CHECK(img.height == 640);
  CHECK(img.at(0, 0) == Rgba8{255, 255, 255, 255});
  CHECK(count(img, noisy.to_rgba8(), 3) > 300);
  CHECK(count(img, denoised.to_rgba8(), 3) > 300);
  CHECK(count(img, truth.to_rgba8(), 3) > 300);
  CHECK(render_trajectory_plot(plot) == img);  // deterministic

  // joint_series from poses: untracked joints become gaps, the offset shifts time.
  std::vector<double> t = {0.0, 0.1};
  std::vector<hs::Pose> poses = {hs::test::synthetic_hand(), hs::untracked_pose()};
  const PlotSeries js = joint_series("tip", noisy, t, poses, hs::idx(hs::Joint::IndexTip), 0.05);
  REQUIRE(js.t.size() == 2);
  CHECK(js.t[1] == doctest::Approx(0.15));
  CHECK(js.xyz[0].y == doctest::Approx(poses[0](hs::idx(hs::Joint::IndexTip), 1)));
  CHECK(std::isnan(js.xyz[1].x));
  CHECK_THROWS_AS(joint_series("x", noisy, {0.0}, poses, 0), std::invalid_argument);
  CHECK_THROWS_AS(joint_series("x", noisy, t, poses, 26), std::invalid_argument);

  // An empty plot still draws axes; all-NaN, single-point and constant series, metres.
  TrajectoryPlot empty;
  empty.width = 300;
  empty.height = 200;
  const Image e = render_trajectory_plot(empty);
  CHECK(count(e, {255, 255, 255, 255}, 0) < 300 * 200);
  empty.millimetres = false;
  empty.series.push_back(PlotSeries{"gaps", noisy, {0.0, 1.0}, {glm::dvec3(nan), glm::dvec3(nan)}, 2.0f});
  empty.series.push_back(PlotSeries{"one", denoised, {0.5}, {glm::dvec3(0.1, 0.2, 0.3)}, 6.0f});
  empty.series.push_back(PlotSeries{"flat", truth, {0.0, 1.0}, {glm::dvec3(1.0), glm::dvec3(1.0)}, 2.0f});
  const Image e2 = render_trajectory_plot(empty);
  CHECK(count(e2, denoised.to_rgba8(), 3) > 10);
  std::filesystem::remove_all(dir);
}

TEST_CASE("errors: bad sizes, bad series, unwritable or unreadable files, no display") {
  CHECK_THROWS_AS(create_offscreen_context(0, 10), std::invalid_argument);
  CHECK_THROWS_AS(create_offscreen_context(10, -1), std::invalid_argument);
  CHECK_THROWS_AS(create_offscreen_context(kMaxImageSide + 1, 10), std::invalid_argument);
  CHECK_THROWS_AS(Image(0, 3), std::invalid_argument);
  CHECK_THROWS_AS(Image(3, kMaxImageSide + 1), std::invalid_argument);
  CHECK_THROWS_AS(Image(2, 2).at(2, 0), std::out_of_range);
  CHECK_THROWS_AS(panel_row(100, 50, 0), std::invalid_argument);
  CHECK_THROWS_AS(panel_row(10, 50, 3, 5), std::invalid_argument);
  CHECK_THROWS_AS(Camera::look_at({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 0.0f, 1.0f), std::invalid_argument);

  const Image img(4, 4);
  CHECK_THROWS_AS(write_png("/nonexistent_dir_hs_render/x.png", img), RenderError);
  try {
    write_png("/nonexistent_dir_hs_render/x.png", img);
  } catch (const RenderError& e) {
    CHECK(std::string(e.what()).find("/nonexistent_dir_hs_render/x.png") != std::string::npos);
  }
  CHECK_THROWS_AS(write_png("/tmp/empty.png", Image{}), std::invalid_argument);
  CHECK_THROWS_AS(read_png("/nonexistent_dir_hs_render/x.png"), RenderError);
  const auto dir = hs::test::temp_dir("render_errors");
  {
    std::FILE* f = std::fopen((dir / "not.png").c_str(), "wb");
    REQUIRE(f != nullptr);
    std::fputs("not a png", f);
    std::fclose(f);
  }
  CHECK_THROWS_AS(read_png(dir / "not.png"), RenderError);
  std::filesystem::remove_all(dir);

  const Image images[] = {img, Image{}};
  CHECK_THROWS_AS(compose_row(std::span<const Image>(), 0), std::invalid_argument);
  CHECK_THROWS_AS(compose_row(images, 0), std::invalid_argument);
  CHECK_THROWS_AS(compose_grid(std::span<const Image>(images, 1), 0), std::invalid_argument);
  CHECK_THROWS_AS(compose_row(std::span<const Image>(images, 1), -1), std::invalid_argument);

  TrajectoryPlot plot;
  plot.width = 0;
  CHECK_THROWS_AS(render_trajectory_plot(plot), std::invalid_argument);
  plot.width = 300;
  plot.series.push_back(PlotSeries{"bad", Color{}, {0.0, 1.0}, {glm::dvec3(0.0)}, 1.0f});
  CHECK_THROWS_AS(render_trajectory_plot(plot), std::invalid_argument);
  plot.series.clear();
  CHECK_THROWS_AS(write_trajectory_plot("/nonexistent_dir_hs_render/plot.png", plot), RenderError);

  // No display: no window, a reason, and the caller falls back to offscreen.
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  const std::string saved_display = display != nullptr ? display : "";
  const std::string saved_wayland = wayland != nullptr ? wayland : "";
  ::unsetenv("DISPLAY");
  ::unsetenv("WAYLAND_DISPLAY");
  CHECK_FALSE(display_available());
  std::string why;
  CHECK(create_window_context(320, 240, "test", &why) == nullptr);
  CHECK_FALSE(why.empty());
  CHECK_THROWS_AS(create_window_context(0, 240, "test"), std::invalid_argument);
  if (display != nullptr) {
    ::setenv("DISPLAY", saved_display.c_str(), 1);
  }
  if (wayland != nullptr) {
    ::setenv("WAYLAND_DISPLAY", saved_wayland.c_str(), 1);
  }
}
