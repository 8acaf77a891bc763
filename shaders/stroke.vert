#version 330 core
// Thick lines and round points for an OpenGL core profile, which has no wide lines.
// Each instance is one segment p0-p1 (a point when p0 == p1) drawn as a capsule of
// radius a_radius pixels: both ends are projected here and gl_VertexID 0..3 picks a
// corner of the screen-space quad (a triangle strip) that covers the capsule plus one
// pixel for the anti-aliased edge. stroke.frag computes the coverage.
layout(location = 0) in vec3 a_p0;
layout(location = 1) in vec3 a_p1;
layout(location = 2) in vec4 a_color;
layout(location = 3) in float a_radius;  // half the line width (point: half the diameter), pixels

uniform mat4 u_mvp;       // world (or overlay pixels) to clip space
uniform vec2 u_viewport;  // viewport size in pixels

noperspective out vec2 v_pixel;  // this corner in viewport pixels (origin bottom-left)
flat out vec2 v_p0;              // the segment's ends in viewport pixels
flat out vec2 v_p1;
flat out float v_radius;
flat out vec4 v_color;

void main() {
  vec4 c0 = u_mvp * vec4(a_p0, 1.0);
  vec4 c1 = u_mvp * vec4(a_p1, 1.0);
  v_color = a_color;
  v_radius = a_radius;
  if (c0.w <= 0.0 || c1.w <= 0.0) {
    // An end at or behind the eye: drop the segment (four equal corners, no area).
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    v_pixel = vec2(0.0);
    v_p0 = vec2(0.0);
    v_p1 = vec2(0.0);
    return;
  }
  vec2 s0 = (c0.xy / c0.w * 0.5 + 0.5) * u_viewport;
  vec2 s1 = (c1.xy / c1.w * 0.5 + 0.5) * u_viewport;
  vec2 d = s1 - s0;
  float len = length(d);
  vec2 dir = len > 1e-4 ? d / len : vec2(1.0, 0.0);
  vec2 normal = vec2(-dir.y, dir.x);
  float e = a_radius + 1.0;
  bool at_end = gl_VertexID >= 2;
  float side = (gl_VertexID & 1) == 0 ? -1.0 : 1.0;
  vec2 corner = (at_end ? s1 + dir * e : s0 - dir * e) + normal * (side * e);
  float z = at_end ? c1.z / c1.w : c0.z / c0.w;
  gl_Position = vec4(corner / u_viewport * 2.0 - 1.0, clamp(z, -1.0, 1.0), 1.0);
  v_pixel = corner;
  v_p0 = s0;
  v_p1 = s1;
}
