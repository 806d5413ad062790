#version 330 core
// normals.frag — the vertex normal of every grid node, one fragment per
// node, into a W × H float texture that surface.vert then fetches.
//
// The positions are a (W+2) × (H+2) float texture: the grid padded with
// one ring of ghost cells filled through the ghost map (ndo_pad,
// DESIGN.md "The regular grid"), so the six lattice neighbours
// (±1,0) (0,±1) (+1,−1) (−1,+1) of every stored node — also on the column
// seam and on the two folded rows — are its true mesh neighbours, and the
// normal comes out the same on both sides of a seam.  At the four
// valence-3 corners each neighbour comes twice and so does each of the
// three triangles: the sum keeps its direction.
//
// Computing the normals once per node here, in llvmpipe's parallel
// fragment stage, costs less than in the vertex shader, which runs on one
// thread and meets each node about twice (docs/bench/render.md).

uniform sampler2D u_position; // node (i, j) at texel (i+1, j+1)

out vec4 normal;

void main()
{
	ivec2 c = ivec2(gl_FragCoord.xy) + 1;
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
	normal = vec4(n, 0.0);
}
