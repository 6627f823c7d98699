#version 450 core
// The sky behind the terrain (the viewer, RenderSettings::sky): a colour by the elevation of the
// view ray through the pixel: deep blue at the zenith, pale at the horizon, a dim haze below it
// (where the view passes the DEM's edge). No depth is written: the terrain covers it.
uniform mat4 u_rayFromClip;  // inverse(projection · view rotation): clip space → eye-relative
uniform vec2 u_viewport;     // pixels

layout(location = 0) out vec4 fragColor;

void main() {
  const vec2 ndc = gl_FragCoord.xy / u_viewport * 2.0 - 1.0;
  const vec4 p = u_rayFromClip * vec4(ndc, 1.0, 1.0);  // on the near plane (reversed-Z: depth 1)
  const float up = normalize(p.xyz / p.w).z;            // the frame's up is +z
  const vec3 zenith = vec3(0.16, 0.36, 0.70);
  const vec3 horizon = vec3(0.70, 0.80, 0.90);
  const vec3 below = vec3(0.30, 0.33, 0.36);
  const vec3 c = up >= 0.0 ? mix(horizon, zenith, pow(up, 0.45)) : mix(horizon * 0.8, below, pow(-up, 0.4));
  fragColor = vec4(c, 1.0);
}
