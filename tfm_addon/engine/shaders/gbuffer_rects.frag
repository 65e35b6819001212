// The G-buffer's pixels a sample shades (adaptive sampling): cleared (nothing seen) and opened to
// the solids (depth 1.0, the far plane); the rest of the frame keeps depth 0.0 and is not drawn.
layout(location = 0) out vec4 o_albedo_distance;
layout(location = 1) out vec4 o_normal_hit;
void main() {
    o_albedo_distance = vec4(0.0);
    o_normal_hit = vec4(0.0);
    gl_FragDepth = 1.0;
}
