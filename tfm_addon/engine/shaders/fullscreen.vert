// A triangle covering the viewport; fragments use gl_FragCoord. With RECTS: triangles given in
// window pixels (adaptive sampling draws only the pixels that still take samples).
#ifdef RECTS
in vec2 in_px;
uniform vec2 u_window;          // the window's size, pixels
#endif
void main() {
#ifdef RECTS
    gl_Position = vec4(in_px / u_window * 2.0 - 1.0, 0.0, 1.0);
#else
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
#endif
}
