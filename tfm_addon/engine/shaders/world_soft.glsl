// A sun standing in for part of the world's light (engine/world_light.py) lights a surface
// from its whole cone of directions, not from its axis alone: its shadows on surfaces are soft, so
// that the suns' overlapping shadows blend into the world's one. Included by scatter.frag after
// light_arriving (FACE_WORLD_SOFT faces).
uniform float u_world_spread;     // tangent of the half angle of the sun's cone of directions
uniform float u_occluder_depth;   // depth of what shadows (the media's centre) below the near plane, m
uniform int u_world_taps;         // directions read per pixel and sample (the frame's samples share the cone)

// The irradiance at the surface point P (qP in face space, nq its normal in face space) from
// the sun's cone: u_world_taps directions spread evenly over the cone's solid angle, turned and
// shifted per pixel and per sample by ``jitter`` (the frame's samples sample the cone between
// them, as they do the lens and the shutter), each weighted by its own cosine on the surface (their mean
// is the cone's mean direction, shorter than its axis: the axis's cosine alone overstates a wide
// cone's light). A ray leaving P at an angle a off the axis crosses what shadows, at depth
// u_occluder_depth, (r - u_occluder_depth) tan(a) beside the axis ray: it is read from the maps
// at the point of P's plane under that crossing (no shadow-map acne on P's own surface). The
// solids' shadow along the axis at P itself gates them all: a solid's shadow in the world's light
// is soft only across the directions, the media's across each cone too.
vec3 world_sun_arriving(vec3 P, vec3 qP, vec3 nq, float jitter) {
    float r0 = light_distance(qP);
    // A solid between P and the sun along the axis shadows every tap: the taps' parallel rays
    // stand for the cone's rays where what shadows lies at the media's depth, not for a solid
    // just above P (a ceiling, a wall), which the cone's rays from P meet too (the world's light
    // would leak into a closed room through the taps read beyond its walls).
    // (Where the axis is behind P's surface, P's own solid is what it meets: the cone's taps
    // above the surface decide alone.)
    float axis_visible = 1.0;
    if (nq.z > 0.0) {
        float bias = g_bias_texels;
        g_bias_texels = surface_bias_texels(nq.z);      // slope-scaled: no acne at grazing axes
        axis_visible = solid_visibility(qP, r0);
        g_bias_texels = bias;
        if (axis_visible <= 0.0) return vec3(0.0);
    }
    float depth = max(r0 - u_occluder_depth, 0.0);
    float cos_h = inversesqrt(1.0 + u_world_spread * u_world_spread);
    float spin = 6.2831853 * fract(jitter + fract(52.9829189 * fract(dot(gl_FragCoord.xy,
                                                                        vec2(0.06711056, 0.00583715)))));
    mat3 to_world = transpose(mat3(u_world_to_light));
    vec3 sum = vec3(0.0);
    for (int k = 0; k < u_world_taps; ++k) {
        float a = spin + 2.39996323 * float(k);
        float c = 1.0 - (float(k) + jitter) / float(u_world_taps) * (1.0 - cos_h);   // uniform over the cap
        float s = sqrt(max(1.0 - c * c, 0.0));
        vec3 w = vec3(s * cos(a), s * sin(a), c);          // toward the sky, face space
        float cosine = dot(nq, w);
        if (cosine <= 0.0) continue;
        vec2 off = depth * (s / c) * vec2(cos(a), sin(a));
        float dz = -dot(nq.xy, off) / max(nq.z, 0.2);     // along P's plane (a grazing one: at most 5x)
        vec3 q = qP + vec3(off, dz);
        float r;
        sum += cosine * light_arriving(P + to_world * vec3(off, dz), q, r);
    }
    return sum * (axis_visible / float(u_world_taps));
}
