// Multiple scattering as octaves of the single scattering (engine/multiple_scattering.py;
// Wrenninge et al. 2013): octave n sees the light's transmittance T^(a^n), adds
// (b albedo (1 - T_through))^n of its light and scatters with anisotropy g c^n, T_through the
// transmittance of the whole light ray through the media (light that scatters again stays in
// thick media and leaves thin ones). OCTAVES 1 (or undefined) is single scattering.
#ifndef OCTAVES
#define OCTAVES 1
#endif
uniform vec3 u_octave;     // a, b, c

// The octaves' sum of contribution x light transmittance x phase at one sample: with one octave
// T hg(cos_theta, g). t_light: the media's transmittance from the light; t_through: along the
// whole light ray (light_through); albedo: the medium's sigma_s / sigma_t there.
vec3 octave_phase(vec3 t_light, vec3 t_through, float cos_theta, float g, vec3 albedo) {
    vec3 s = t_light * hg_phase(cos_theta, g);
#if OCTAVES > 1
    vec3 log_t = log2(max(t_light, vec3(1e-30)));
    vec3 step_b = u_octave.y * clamp(albedo, 0.0, 1.0) * (1.0 - t_through);
    float an = 1.0;
    vec3 bn = vec3(1.0);
    float gn = g;
    for (int n = 1; n < OCTAVES; ++n) {
        an *= u_octave.x;
        bn *= step_b;
        gn *= u_octave.z;
        s += bn * exp2(an * log_t) * hg_phase(cos_theta, gn);
    }
#endif
    return s;
}

#if OCTAVES > 1 && HAS_LIGHT
// The media's transmittance along the whole light ray through p (q: p in light space, r: its
// light distance), from where the ray enters them to where it leaves (or meets a solid). Called
// after light_transmittance(p, q, r): a map gives it from the same lookup (its series at the far
// end); otherwise the transmittance from the light to where the ray leaves the media beyond p.
vec3 light_through(vec3 p, vec3 q, float r) {
#if LIGHT_T == 0
    // the map's far end, from the lookup light_transmittance(p, q, r) made (transmittance.glsl)
    return EXP2_RGB(u_tfm_exponent * log2(max(g_tfm_end, 1e-30)));
#elif MEDIUM == 2
    return vec3(0.0);       // fog everywhere: no way out
#else
    vec3 dir = toward_light(p, q, r);
#if MEDIUM == 3
    float beyond = media_interval(p, -dir).y;
#else
    float beyond = box_interval(p, -dir).y;
#endif
    if (beyond <= 0.0) return light_transmittance(p, q, r);
    vec3 pe = p - dir * beyond;
    vec3 qe = light_space(pe);
    return light_transmittance(pe, qe, light_distance(qe));
#endif
}
#else
vec3 light_through(vec3 p, vec3 q, float r) { return vec3(1.0); }
#endif
