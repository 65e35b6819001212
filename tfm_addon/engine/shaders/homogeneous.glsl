// Light scattered by a homogeneous medium along a view ray, and the world's fog without bounds
// beside marched media (WORLD_FOG). Included by scatter.frag after light_arriving and
// frustum_interval.

#if HAS_LIGHT
// The light of this pass scattered toward the camera along the part cs of the ray (o, d) by a
// homogeneous medium (sigma_t, sigma_s, g), seen through exp(-sigma_t (t - t0)): u_view_steps
// steps, spaced uniformly in the light's map space where ``projective`` (method, section 4.2),
// each weighted by its exact share of the view transmittance and lit as seen from the camera on
// average (the march in scatter.frag).
vec3 homogeneous_light(vec3 o, vec3 d, vec2 cs, float t0, vec3 sigma_t, vec3 sigma_s, float g,
                       float step_at, bool projective) {
    vec3 scatter = vec3(0.0);
    if (cs.y <= cs.x) return scatter;
    vec3 oq = light_space(o);
    vec3 dq = mat3(u_world_to_light) * d;
    int n = u_view_steps;
    float w_in = 0.0;
    float w_out = 0.0;
    if (projective) {
        vec3 qa = light_space(o + d * cs.x);
        vec3 qb = light_space(o + d * cs.y);
        w_in = -qa.z;
        w_out = -qb.z;
        projective = u_face_ortho == 0 && min(w_in, w_out) > 1e-6 * max(w_in, w_out)
                  && length(light_uv(qb) - light_uv(qa)) * u_map_res > 1.0;   // ortho: affine
    }
    float span = cs.y - cs.x;
    float s_prev = 0.0;
    for (int i = 0; i < n; ++i) {
        float s_mid = (float(i) + step_at) / float(n);
        float s_next = float(i + 1) / float(n);
        float u_mid = s_mid;
        float u_next = s_next;
        if (projective) {
            u_mid = s_mid * w_in / ((1.0 - s_mid) * w_out + s_mid * w_in);
            u_next = s_next * w_in / ((1.0 - s_next) * w_out + s_next * w_in);
        }
        float dt = (u_next - s_prev) * span;
        float t_start = cs.x + s_prev * span;
        float at = (u_mid - s_prev) * span / max(dt, 1e-30);    // the sample's place in the step
        s_prev = u_next;
        float t = t_start + 2.0 * at * seen_fraction(dot(sigma_t, vec3(dt / 3.0))) * dt;
        vec3 q = oq + dq * t;
        float r;
        vec3 t_light;
        vec3 li = light_reaching(o + d * t, q, r, t_light);
        if (any(greaterThan(li, vec3(0.0)))) {
            vec3 tau_v = sigma_t * (t - t0);
            vec3 w_step = exp(-sigma_t * (t_start - t0)) * step_integral(sigma_t, dt, exp(-sigma_t * dt));
            scatter += w_step * sigma_s * li * u_light_targets.x
                       * octave_phase(t_light, light_through(o + d * t, q, r, t_light), tau_v, -dot(light_travel(q, r), dq),
                                      g, sigma_s / max(sigma_t, vec3(1e-12)));
        }
    }
    return scatter;
}
#endif

#if WORLD_FOG
// The fog alone on the part ab of the ray: this pass's light (and, on the first pass, the ambient
// light in closed form), as seen from ab.x; its samples always follow the light's map space.
vec3 fog_piece(vec3 o, vec3 d, vec2 ab, float step_at) {
    vec3 scatter = vec3(0.0);
    if (ab.y <= ab.x) return scatter;
#if FIRST_PASS
    scatter += u_fog_sigma_s / max(u_fog_sigma_t, vec3(1e-12)) * u_ambient
             * (1.0 - exp(-u_fog_sigma_t * (ab.y - ab.x)));
#endif
#if HAS_LIGHT
    scatter += homogeneous_light(o, d, frustum_interval(o, d, ab), ab.x, u_fog_sigma_t, u_fog_sigma_s,
                                 u_fog_g, step_at, true);
#endif
    return scatter;
}

// The fog on the view ray's span (t_near, t_end) outside seg, the media's marched segment (whose
// march added the fog inside it and the fog before it to its transmittance): before seg seen
// directly, after it through ``transmittance``, the transmittance at seg's end, which leaves as
// the whole span's.
void world_fog_outside(vec3 o, vec3 d, vec2 span, vec2 seg, float step_at, inout vec3 scatter,
                       inout vec3 transmittance) {
    bool marched = seg.y > seg.x;
    vec2 before = marched ? vec2(span.x, seg.x) : span;
    vec2 after = marched ? vec2(seg.y, span.y) : vec2(span.y);
    scatter += fog_piece(o, d, before, step_at);
    scatter += transmittance * fog_piece(o, d, after, step_at);
    float outside = marched ? after.y - after.x : before.y - before.x;
    transmittance *= exp(-u_fog_sigma_t * outside);
}
#endif
