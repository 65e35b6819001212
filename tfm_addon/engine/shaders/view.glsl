// The camera's view plane: the direction of a pixel's ray (scatter.frag's march, compose.glsl's
// background).
#ifndef VIEW_GLSL
#define VIEW_GLSL
uniform mat4 u_camera_to_world;
uniform vec2 u_plane0;         // camera-space x, y of the window's lower-left corner (unit depth)
uniform float u_pixel_size;    // at unit depth (perspective) or in metres (orthographic)
uniform int u_ortho;

// The unit world direction through window point ``frag`` (pixels from the lower-left corner).
vec3 view_direction(vec2 frag) {
    if (u_ortho == 1) return normalize(mat3(u_camera_to_world) * vec3(0.0, 0.0, -1.0));
    return normalize(mat3(u_camera_to_world) * vec3(u_plane0 + frag * u_pixel_size, -1.0));
}
#endif
