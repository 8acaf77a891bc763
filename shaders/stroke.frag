#version 330 core
// Coverage of a capsule (see stroke.vert): distance from the pixel centre to the segment,
// full inside the radius, fading over one pixel at the edge (anti-aliasing).
noperspective in vec2 v_pixel;
flat in vec2 v_p0;
flat in vec2 v_p1;
flat in float v_radius;
flat in vec4 v_color;

out vec4 o_color;

void main() {
  vec2 d = v_p1 - v_p0;
  float l2 = dot(d, d);
  float h = l2 > 0.0 ? clamp(dot(v_pixel - v_p0, d) / l2, 0.0, 1.0) : 0.0;
  float dist = length(v_pixel - v_p0 - d * h);
  float coverage = clamp(v_radius - dist + 0.5, 0.0, 1.0);
  if (coverage <= 0.0) {
    discard;
  }
  o_color = vec4(v_color.rgb, v_color.a * coverage);
}
