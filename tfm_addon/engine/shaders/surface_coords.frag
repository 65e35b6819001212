// The texture coordinates of the textured surfaces the G-buffer sees (drawn over its depth):
// object-space position and UV.
in vec3 v_object;
in vec2 v_uv;
layout(location = 0) out vec4 o_object_u;
layout(location = 1) out vec4 o_v;
void main() {
    o_object_u = vec4(v_object, v_uv.x);
    o_v = vec4(v_uv.y, 0.0, 0.0, 1.0);
}
