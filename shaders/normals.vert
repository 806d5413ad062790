#version 330 core
// normals.vert — one triangle covering the viewport (render-frame's normal
// pass, shaders/normals.frag): no vertex data, three corners from
// gl_VertexID.
void main()
{
	vec2 corner = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
	gl_Position = vec4(corner, 0.0, 1.0);
}
