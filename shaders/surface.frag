#version 330 core
// surface.frag — Blinn–Phong shading of the grid surface (render-frame;
// thesis appendix C), with the optional procedural cloth of thesis
// figure 5.1b and a wireframe drawn from the lattice coordinates.
// render-frame prepends "#define COLOR_MODE n", CLOTH, WIREFRAME and FLAT.


in vec3 v_normal;
in vec3 v_eye;
in vec2 v_grid;

uniform vec3 u_light;     // unit vector towards the light, eye space
uniform vec4 u_material;  // ambient, diffuse, specular, shininess
uniform vec3 u_color;     // solid colour

#if COLOR_MODE == 1
in vec3 v_color;
#elif COLOR_MODE == 2
in float v_value;
uniform sampler2D u_colormap; // 256 × 1 RGB: the colour map
#endif

#if CLOTH
uniform float u_cloth_period; // lattice units per thread
#endif

#if WIREFRAME
uniform float u_wire_step;   // lattice units between drawn grid lines
uniform float u_wire_width;  // pixels
uniform vec4 u_wire_color;   // rgb, opacity
#endif

out vec4 frag_color;

const float PI = 3.14159265358979;

#if CLOTH
// A plain weave: warp threads along the lattice's i axis, weft threads
// along j, each crossing over and under alternately.  Returns the albedo
// factor and bends `n` across the thread on top (a round thread profile),
// in the tangent frame of the screen-space derivatives (Schüler 2006,
// "Normal mapping without precomputed tangents"), so no tangents are
// uploaded.  Thesis figure 5.1b used a cloth image and a normal map; this
// is procedural, with the thesis' noise for the irregular yarn.
float cloth(inout vec3 n, vec3 eye)
{
	vec2 t = v_grid / u_cloth_period;
	vec2 cell = floor(t);
	vec2 f = t - cell;
	bool warp_up = mod(cell.x + cell.y, 2.0) < 1.0;
	// Across the thread on top: f.y for a warp thread (it runs along i).
	float across = warp_up ? f.y : f.x;
	float along = warp_up ? f.x : f.y;
	float profile = sin(PI * across);                  // 0 at the gaps, 1 on the crest
	float dip = 0.75 + 0.25 * sin(PI * along);         // where it dives under the other
	float slope = cos(PI * across);                    // d(height)/d(across), −1..1
	// The thesis' yarn noise (appendix C), in thread units.
	float noise = sin(13.0 * cos(t.y * 11.0)) + cos(11.0 * sin(t.x * 13.0));
	float albedo = (0.55 + 0.45 * profile * dip) * (0.9 + 0.1 * mod(noise, 0.3) / 0.3);

	// Fade the pattern when a thread covers under about two pixels: a
	// pattern finer than the pixels only aliases.
	vec2 w = fwidth(t);
	float fade = clamp(1.5 - 2.0 * max(w.x, w.y), 0.0, 1.0);

	vec3 dp1 = dFdx(eye), dp2 = dFdy(eye);
	vec2 duv1 = dFdx(v_grid), duv2 = dFdy(v_grid);
	vec3 dp2perp = cross(dp2, n), dp1perp = cross(n, dp1);
	vec3 T = dp2perp * duv1.x + dp1perp * duv2.x;
	vec3 B = dp2perp * duv1.y + dp1perp * duv2.y;
	float s = inversesqrt(max(max(dot(T, T), dot(B, B)), 1e-30));
	vec3 dir = (warp_up ? B : T) * s; // direction across the thread on top
	n = normalize(n - 0.6 * fade * slope * dir);
	return mix(0.775, albedo, fade);
}
#endif

void main()
{
#if FLAT
	// The triangle's own normal, from the screen-space derivatives of
	// the eye-space position: the facets of a coarse grid as they are.
	vec3 n = normalize(cross(dFdx(v_eye), dFdy(v_eye)));
#else
	vec3 n = normalize(v_normal);
	if (!gl_FrontFacing)
		n = -n; // seen from inside (an open or self-crossing surface)
#endif
	vec3 base;
#if COLOR_MODE == 1
	base = v_color;
#elif COLOR_MODE == 2
	base = texture(u_colormap, vec2(clamp(v_value, 0.0, 1.0), 0.5)).rgb;
#else
	base = u_color;
#endif
	float spec_scale = 1.0;
#if CLOTH
	float a = cloth(n, v_eye);
	base *= a;
	spec_scale = a * a;
#endif
	vec3 v = normalize(-v_eye);
	vec3 h = normalize(u_light + v);
	float ndotl = max(dot(n, u_light), 0.0);
	float spec = ndotl > 0.0 ? pow(max(dot(n, h), 0.0), u_material.w) : 0.0;
	vec3 color = base * (u_material.x + u_material.y * ndotl) +
	             vec3(u_material.z * spec * spec_scale);
#if WIREFRAME
	// Grid lines are where i, j or i + j is a multiple of the step (the
	// cell diagonal runs from (i+1, j) to (i, j+1)): distance in pixels
	// from the nearest, through the screen-space derivatives.
	vec3 g = vec3(v_grid, v_grid.x + v_grid.y) / u_wire_step;
	vec3 d = abs(g - round(g)) / max(fwidth(g), vec3(1e-6));
	float dist = min(min(d.x, d.y), d.z);
	float line = 1.0 - smoothstep(0.5 * u_wire_width - 0.5, 0.5 * u_wire_width + 0.5, dist);
	color = mix(color, u_wire_color.rgb, line * u_wire_color.a);
#endif
	frag_color = vec4(color, 1.0);
}
