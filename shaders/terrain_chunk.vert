#version 450 core
// A quadtree chunk vertex is an index (i, j) into the chunk's grid plus a height. Its position
// comes from integers: the global post index, made relative to the post nearest the eye, times
// the post spacing. Every chunk computes a shared vertex from the same integers with the same
// float operations, so neighbouring chunks meet bit for bit; u_modelViewProj holds the
// translation to that post, formed in double on the CPU.
layout(location = 0) in uvec2 a_ij;
layout(location = 1) in float a_height;

uniform mat4 u_modelViewProj;
uniform ivec2 u_chunkBase;  // global post index of vertex (0, 0)
uniform int u_level;        // posts between vertices = 2^level
uniform ivec2 u_eyePost;    // the frame-wide centre, as a post index
uniform vec2 u_step;        // metres per post (y negative for north-up grids)
uniform float u_exaggeration;
uniform vec2 u_uvBase;      // imagery uv at the centre
uniform vec2 u_uvScale;     // uv per metre
uniform vec2 u_drapeUvBase;   // texture drape: uv at the centre
uniform vec2 u_drapeUvScale;  // and per metre

out vec3 v_position;
out float v_height;  // true (unexaggerated) height, for the elevation ramp
out vec2 v_uv;
out vec2 v_drapeUv;

void main() {
  ivec2 post = u_chunkBase + (ivec2(a_ij) << u_level);
  vec2 xy = vec2(post - u_eyePost) * u_step;
  vec3 p = vec3(xy, a_height * u_exaggeration);
  v_position = p;
  v_height = a_height;
  v_uv = u_uvBase + xy * u_uvScale;
  v_drapeUv = u_drapeUvBase + xy * u_drapeUvScale;
  gl_Position = u_modelViewProj * vec4(p, 1.0);
}
