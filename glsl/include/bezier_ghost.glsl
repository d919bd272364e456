// Walch 2017's measured-ghost primitive (src/optics/bezier_ghost.rs): the word layout of one
// primitive in the BezierGhosts buffer and the 12-step search for its signed distance. The
// integer defines are shared with Rust (realcam::gpu::shaders::bezier_ghost).
#ifndef REALCAM_BEZIER_GHOST_GLSL
#define REALCAM_BEZIER_GHOST_GLSL

// Words per primitive: bounds x0 y0 x1 y1 (image px), centre x y, height, left, right, left
// control, right control, I_b, I_i, F_i, F_o, E_i, E_o, colour r g b, cos and sin of the roll,
// the roll's pivot x y.
#define BEZIER_WORDS 24
#define BEZIER_BOUNDS 0
#define BEZIER_SHAPE 4
#define BEZIER_TRANSFER 11
#define BEZIER_COLOUR 17
#define BEZIER_ROLL 20
// Coarse samples per side before the 12 halvings.
#define BEZIER_COARSE 8
#define BEZIER_STEPS 12

// Eq 6.1 for control points given relative to the query point.
vec2 bezier_at(vec2 p0, vec2 p1, vec2 p2, vec2 p3, float t) {
    float s = 1.0 - t;
    return s * s * s * p0 + 3.0 * s * s * t * p1 + 3.0 * s * t * t * p2 + t * t * t * p3;
}

vec2 bezier_tangent(vec2 p0, vec2 p1, vec2 p2, vec2 p3, float t) {
    float s = 1.0 - t;
    return 3.0 * s * s * (p1 - p0) + 6.0 * s * t * (p2 - p1) + 3.0 * t * t * (p3 - p2);
}

// Half the derivative of the squared distance: (C(t) - Q) . C'(t), Q at the origin.
float bezier_slope(vec2 p0, vec2 p1, vec2 p2, vec2 p3, float t) {
    return dot(bezier_at(p0, p1, p2, p3, t), bezier_tangent(p0, p1, p2, p3, t));
}

// The distance from the origin to one side (control points relative to the query point) and
// eq 6.3's sign there (x: distance, y: +1 inside). The best of BEZIER_COARSE + 1 samples, then
// BEZIER_STEPS halvings of the bracket around it keeping the half where the squared distance's
// derivative changes sign (Walch sec. 6.3.2 halves by the midpoints' distances), then the
// secant of the derivative in the last bracket.
vec2 bezier_side_distance(vec2 p0, vec2 p1, vec2 p2, vec2 p3) {
    float best_t = 0.0;
    float best = 3.4e38;
    for (int k = 0; k <= BEZIER_COARSE; ++k) {
        float t = float(k) / float(BEZIER_COARSE);
        float d = dot(bezier_at(p0, p1, p2, p3, t), bezier_at(p0, p1, p2, p3, t));
        if (d < best) { best = d; best_t = t; }
    }
    float lo = max(best_t - 1.0 / float(BEZIER_COARSE), 0.0);
    float hi = min(best_t + 1.0 / float(BEZIER_COARSE), 1.0);
    float g_lo = bezier_slope(p0, p1, p2, p3, lo);
    float g_hi = bezier_slope(p0, p1, p2, p3, hi);
    for (int i = 0; i < BEZIER_STEPS; ++i) {
        float m = 0.5 * (lo + hi);
        float g = bezier_slope(p0, p1, p2, p3, m);
        // The distance grows past m: the minimum lies before it.
        if (g > 0.0) { hi = m; g_hi = g; } else { lo = m; g_lo = g; }
    }
    float t = (g_lo < 0.0 && g_hi > 0.0) ? lo + (hi - lo) * g_lo / (g_lo - g_hi) : (g_lo >= 0.0 ? lo : hi);
    vec2 b = bezier_at(p0, p1, p2, p3, t);
    vec2 tangent = bezier_tangent(p0, p1, p2, p3, t);
    // A vanishing tangent (a control point on its end): its limit.
    if (length(tangent) <= 1e-6 * (length(p3 - p0) + 1e-30)) tangent = t < 0.5 ? p2 - p0 : p3 - p1;
    // Eq 6.3: sign(rot_tangent . (B - Q)), Q at the origin.
    float sign_in = dot(vec2(-tangent.y, tangent.x), b) >= 0.0 ? 1.0 : -1.0;
    return vec2(length(b), sign_in);
}

// Eq 6.4 with S = |d| / F (0 on the border: I_b there); F = 0 a step.
float bezier_transfer(float d, float border, float inner, float fi, float fo, float ei, float eo) {
    if (isnan(d)) return 0.0;
    bool out_side = d < 0.0;
    float f = out_side ? fo : fi;
    float e = max(out_side ? eo : ei, 1e-6);
    float w = f > 0.0 ? pow(min(abs(d) / f, 1.0), e) : (d == 0.0 ? 0.0 : 1.0);
    return mix(border, out_side ? 0.0 : inner, clamp(w, 0.0, 1.0));
}

#endif
