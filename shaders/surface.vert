#version 330 core
// surface.vert — one grid node per vertex (render-frame; thesis appendix C).
//
// The draw call has no vertex attributes: gl_VertexID is the stored index
// j·W + i of node (i, j); the node's position is fetched from a float
// texture (the thesis' vertex texture fetch) and its normal from the
// texture the normal pass (normals.frag) made from the six neighbours.
//
// render-frame prepends "#define COLOR_MODE n" (0 solid, 1 owner,
// 2 scalar), CLOTH, WIREFRAME and FLAT after the #version line.

uniform sampler2D u_position; // (W+2) × (H+2) RGB32F, node (i, j) at texel (i+1, j+1)
uniform sampler2D u_normal;   // W × H RGBA32F, from normals.frag
uniform int u_width;          // W
uniform mat4 u_modelview;     // rigid: its upper 3×3 also turns normals
uniform mat4 u_projection;

out vec3 v_normal; // eye space, not normalized
out vec3 v_eye;    // eye-space position
out vec2 v_grid;   // lattice coordinates (i, j): cloth and wireframe

#if COLOR_MODE == 1
uniform isampler2D u_owner;   // W × H R32I: owner channel
uniform vec3 u_palette[8];         // a peer's place in the partition → colour
uniform vec3 u_unowned;
out vec3 v_color;             // blended across the triangles between two peers
#elif COLOR_MODE == 2
uniform sampler2D u_scalar;   // W × H R32F
uniform vec2 u_range;         // values mapped to 0 and 1
out float v_value;
#endif

void main()
{
	ivec2 ij = ivec2(gl_VertexID % u_width, gl_VertexID / u_width);
	ivec2 c = ij + 1;
	vec3 p = texelFetch(u_position, c, 0).xyz;
	vec3 n = texelFetch(u_normal, ij, 0).xyz; // area-weighted, not normalized
	vec4 eye = u_modelview * vec4(p, 1.0);
	v_eye = eye.xyz;
	v_normal = mat3(u_modelview) * n;
	v_grid = vec2(ij);
	gl_Position = u_projection * eye;

#if COLOR_MODE == 1
	int owner = texelFetch(u_owner, ij, 0).r;
	v_color = owner < 0 ? u_unowned : u_palette[owner % 8];
#elif COLOR_MODE == 2
	float s = texelFetch(u_scalar, ij, 0).r;
	v_value = (s - u_range.x) / (u_range.y - u_range.x);
#endif
}
