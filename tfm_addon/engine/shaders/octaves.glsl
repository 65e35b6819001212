// Multiple scattering as octaves of the single scattering (engine/multiple_scattering.py;
// Wrenninge et al. 2013): octave n sees the light's transmittance T^(a^n), adds
// (b albedo (1 - T_through))^n of its light and scatters with anisotropy g c^n, T_through the
// transmittance of the whole light ray through the media (light that scatters again stays in
// thick media and leaves thin ones). A diffusion term (weight k albedo^m) adds the light scattered
// many times in thick media, which the octaves' T^(a^n) leave too dark deep inside; SLAB 1 compiles
// it in (only where no lattice's fields stand for it). OCTAVES 1 (or undefined) is single
// scattering.
#ifndef OCTAVES
#define OCTAVES 1
#endif
#ifndef SLAB
#define SLAB 0
#endif
#if GREY_EXTINCTION
#define LOG2_RGB(v) vec3(log2((v).x))
#else
#define LOG2_RGB(v) log2(v)
#endif
const float LN2 = 0.693147180559945;
uniform vec3 u_octave;     // a, b, c
uniform vec3 u_diffusion;  // k, z, m

// Diffuse fluence over the light's irradiance at optical depth tau from the light in a slab of
// optical thickness tau_tot along the light ray (the diffusion approximation, isotropic, boundary
// extrapolated by z): 3 albedo / (kappa^2 - 1) (e^-tau - e^z S), S the homogeneous solution
// sinh(kappa (tau_tot + z - tau)) / sinh(kappa (tau_tot + 2 z)), kappa^2 = 3 (1 - albedo).
vec3 diffuse_fluence(vec3 tau, vec3 tau_tot, vec3 albedo) {
    float z = u_diffusion.y;
    vec3 k2 = 3.0 * (1.0 - albedo);
    k2 = mix(k2, vec3(1.02), lessThan(abs(k2 - 1.0), vec3(0.02)));    // removable singularity at 1
    vec3 kap = sqrt(max(k2, vec3(1e-8)));
    vec3 a = tau_tot + z - max(tau, vec3(0.0));
    vec3 b = tau_tot + 2.0 * z;
    // sinh(kap a) / sinh(kap b) without overflow; a / b as kappa -> 0
    vec3 s = mix(exp(kap * (a - b)) * (1.0 - exp(-2.0 * kap * a)) / max(1.0 - exp(-2.0 * kap * b), vec3(1e-6)),
                 a / b, lessThan(kap, vec3(1e-3)));
    return max(3.0 * albedo / (k2 - 1.0) * (exp(-tau) - exp(z) * s), vec3(0.0));
}

// The octaves' sum of contribution x light transmittance x phase at one sample: with one octave
// T hg(cos_theta, g). t_light: the media's transmittance from the light; tau_through: their optical
// depth along the whole light ray (light_through); tau_view: the view's optical depth from the
// camera to the sample; albedo: the medium's sigma_s / sigma_t there.
vec3 octave_phase(vec3 t_light, vec3 tau_through, vec3 tau_view, float cos_theta, float g, vec3 albedo) {
    vec3 s = t_light * hg_phase(cos_theta, g);
#if OCTAVES > 1
    // grey extinction: one channel's exponentials and logarithm serve all three
    vec3 t_through = EXP_RGB(-tau_through);
    vec3 log_t = LOG2_RGB(max(t_light, vec3(1e-30)));
    vec3 step_b = u_octave.y * clamp(albedo, 0.0, 1.0) * (1.0 - t_through);
    float an = 1.0;
    vec3 bn = vec3(1.0);
    float gn = g;
    for (int n = 1; n < OCTAVES; ++n) {
        an *= u_octave.x;
        bn *= step_b;
        gn *= u_octave.z;
        s += bn * EXP2_RGB(an * log_t) * hg_phase(cos_theta, gn);
    }
#if SLAB
    {
        // the light scattered many times, spread evenly over directions
        vec3 tau = -log(max(t_light, vec3(1e-37)));
        vec3 tau_tot = max(tau_through, tau);
        // The slab has free faces toward the light and away from it only: where the view enters
        // the medium nearer (a silhouette, a crease in a lobe's shadow) the light leaks out there
        // too, the fluence falling as the distance to that face (diffusion: linear, plus z).
        vec3 z = vec3(u_diffusion.y);
        vec3 near = min(vec3(1.0), (tau_view + z) / (min(tau, tau_tot - tau) + z));
        vec3 alb = clamp(albedo, 0.0, 1.0);
        s += u_diffusion.x * pow(alb, vec3(u_diffusion.z)) * near * diffuse_fluence(tau, tau_tot, alb)
             * (0.25 / PI);
    }
#endif
#endif
    return s;
}

#if OCTAVES > 1 && HAS_LIGHT
// The media's optical depth along the whole light ray through p (q: p in light space, r: its
// light distance), from where the ray enters them to where it leaves (or meets a solid). Called
// after light_transmittance(p, q, r), which gave t_light: a map gives it from the same lookup (its
// series at the far end, without the underflow of its transmittance); otherwise from the light to
// where the ray leaves the media beyond p (a lone homogeneous box: t_light's depth plus its
// extinction over the rest of the ray inside it).
vec3 light_through(vec3 p, vec3 q, float r, vec3 t_light) {
#if LIGHT_T == 0
    // the map's far end, from the lookup light_transmittance(p, q, r) made (transmittance.glsl)
    return -u_tfm_exponent * log(max(g_tfm_end, 1e-30));
#elif MEDIUM == 2
    return vec3(1e30);       // fog everywhere: no way out
#elif MEDIUM == 1 && LIGHT_T == 2
    // one homogeneous box: the light ray's optical depth to p plus the box's extinction behind p,
    // whose extent the lookup found
    return -LN2 * LOG2_RGB(max(t_light, vec3(1e-37))) + u_sigma_t * g_box_behind;
#else
    vec3 dir = toward_light(p, q, r);
#if MEDIUM == 3
    float beyond = media_interval(p, -dir).y;
#else
    float beyond = box_interval(p, -dir).y;
#endif
    vec3 tau_light = -LN2 * LOG2_RGB(max(t_light, vec3(1e-37)));
    if (beyond <= 0.0) return tau_light;
#if MEDIUM == 1
    // one homogeneous box: the light ray's optical depth to p plus the box's extinction beyond it
    return tau_light + u_sigma_t * beyond;
#else
    vec3 pe = p - dir * beyond;
    vec3 qe = light_space(pe);
    return -log(max(light_transmittance(pe, qe, light_distance(qe)), vec3(1e-37)));
#endif
#endif
}
#else
vec3 light_through(vec3 p, vec3 q, float r, vec3 t_light) { return vec3(0.0); }
#endif
