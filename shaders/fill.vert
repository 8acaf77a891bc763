#version 330 core
// Filled triangles (rectangles, the writing plane): one colour per vertex.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_color;

uniform mat4 u_mvp;  // world (or overlay pixels) to clip space

out vec4 v_color;

void main() {
  v_color = a_color;
  gl_Position = u_mvp * vec4(a_position, 1.0);
}
