// The light of one face reaching a point: its emission profile, the solids' shadow, the gobo and
// the media's transmittance (the camera passes and the probe pass).
// Radiance arriving at p (q in light space) from the light face past the solids, before the
// media; t_light is set to the media's transmittance from the light and r to the light distance
// (light.py: the faces of a point light split the sphere).
vec3 light_reaching(vec3 p, vec3 q, out float r, out vec3 t_light) {
    r = light_distance(q);
    t_light = vec3(1.0);
    if (!in_face(q)) return vec3(0.0);
#if SOFT_SHADOW
    soft_next();        // the point's light sample (soft_shadow.glsl)
#endif
    float emit = emission_profile(q, r);
    if (emit <= 0.0) return vec3(0.0);
    vec2 uv = light_uv(q);
    float vis = solid_visibility(q, r);
    if (vis <= 0.0) return vec3(0.0);
    t_light = light_transmittance(p, q, r);
    return u_intensity * (emit * vis) * gobo(uv);
}

// The same past the media too.
vec3 light_arriving(vec3 p, vec3 q, out float r) {
    vec3 t_light;
    vec3 li = light_reaching(p, q, r, t_light);
    return li * t_light;
}
