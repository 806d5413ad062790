#version 330 core
// surface.vert — one grid node per vertex (render-frame; thesis appendix C).
//
// The draw call has no vertex attributes: gl_VertexID is the stored index
// j·W + i of node (i, j), and the node's position is fetched from a float
// texture (the thesis' vertex texture fetch).  The texture holds the grid
// padded with one ring of ghost cells filled through the ghost map
// (ndo_pad, DESIGN.md "The regular grid"), so the six lattice neighbours
// (±1,0) (0,±1) (+1,−1) (−1,+1) of every stored node — also on the column
// seam and on the two folded rows — are its true mesh neighbours, and the
// normal comes out the same on both sides of a seam.  At the four
// valence-3 corners each neighbour comes twice and so does each of the
// three triangles: the sum keeps its direction.
//
// render-frame prepends "#define COLOR_MODE n" (0 solid, 1 owner,
// 2 scalar), CLOTH and WIREFRAME after the #version line.


uniform sampler2D u_position; // (W+2) × (H+2) RGB32F, node (i, j) at texel (i+1, j+1)
uniform int u_width;          // W
uniform mat4 u_modelview;     // rigid: its upper 3×3 also turns normals
uniform mat4 u_projection;

out vec3 v_normal; // eye space, not normalized (area-weighted)
out vec3 v_eye;    // eye-space position
out vec2 v_grid;   // lattice coordinates (i, j): cloth and wireframe

#if COLOR_MODE == 1
uniform isampler2D u_owner;   // W × H R32I: owner channel
uniform vec3 u_palette[10];
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
	// Edge vectors to the six neighbours, counter-clockwise (ndo_dirs).
	vec3 e0 = texelFetch(u_position, c + ivec2(1, 0), 0).xyz - p;
	vec3 e1 = texelFetch(u_position, c + ivec2(0, 1), 0).xyz - p;
	vec3 e2 = texelFetch(u_position, c + ivec2(-1, 1), 0).xyz - p;
	vec3 e3 = texelFetch(u_position, c + ivec2(-1, 0), 0).xyz - p;
	vec3 e4 = texelFetch(u_position, c + ivec2(0, -1), 0).xyz - p;
	vec3 e5 = texelFetch(u_position, c + ivec2(1, -1), 0).xyz - p;
	// Sum of the six triangles' normals, each twice its area: the
	// area-weighted vertex normal, outward for counter-clockwise faces.
	vec3 n = cross(e0, e1) + cross(e1, e2) + cross(e2, e3) + cross(e3, e4) +
	         cross(e4, e5) + cross(e5, e0);

	vec4 eye = u_modelview * vec4(p, 1.0);
	v_eye = eye.xyz;
	v_normal = mat3(u_modelview) * n;
	v_grid = vec2(ij);
	gl_Position = u_projection * eye;

#if COLOR_MODE == 1
	int owner = texelFetch(u_owner, ij, 0).r;
	v_color = owner < 0 ? u_unowned : u_palette[owner % 10];
#elif COLOR_MODE == 2
	float s = texelFetch(u_scalar, ij, 0).r;
	v_value = (s - u_range.x) / (u_range.y - u_range.x);
#endif
}
