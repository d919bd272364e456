// Anti-aliased edges: which layer's light a pixel holds. Shared by the depth of field's edge
// resolve (glsl/dof/coc_edges.comp: which depth, hence CoC) and the motion blur's
// (glsl/motion/mb_edges.comp: which velocity and depth); the CPU twin is src/passes/edge_layers.rs.
//
// Renderers filter the colour pass over about 1.5 px but take depth and vectors from one sample
// per pixel, so a pixel at an edge may carry one surface's depth and velocity and mostly another
// surface's light (a bright in-focus point's fringe with the sky's depth, or with a moving
// sphere's velocity). Where the 3x3 neighbourhood spans two layers (the caller decides when: a
// CoC or a motion difference), the pixel's colour is read as a mix of the two layers' colours
// (the near neighbours' mean, the far neighbour of median brightness; least squares for the near
// layer's share alpha), and it belongs to the layer that brings more of its light: alpha L_near
// against (1 - alpha) L_far. A near pixel whose alpha lies within the range of the near layer's
// pixels (a textured surface at a hard edge) keeps its layer. The far layer gets no such test: at
// an anti-aliased fringe the far neighbours are fringe pixels too, and would explain each other;
// `min_share` (0 for the depth of field) asks instead that the other layer bring at least that
// share of the pixel's light before the pixel changes layers.
//
// Needs finite_or_zero (common.glsl).
#ifndef REALCAM_EDGE_LAYERS_GLSL
#define REALCAM_EDGE_LAYERS_GLSL

#define EDGE_OWN 0
#define EDGE_NEAR 1
#define EDGE_FAR 2

float edge_brightness(vec3 c) { return max(c.r, 0.0) + max(c.g, 0.0) + max(c.b, 0.0); }

// The layer whose light the pixel holds: EDGE_OWN (its own), EDGE_NEAR or EDGE_FAR. w: the
// layer keys of the 3x3 neighbourhood in row order (inverse depth: larger is nearer; w[4] the
// pixel's own), w_near and w_far their largest and smallest; c9: the neighbours' colours (c9[4]
// unused), c_p the pixel's. The near layer is every neighbour with w above the middle of the two.
int edge_layer(float w[9], vec3 c9[9], vec3 c_p, float w_near, float w_far, float min_share) {
    float w_p = w[4];
    float w_mid = 0.5 * (w_near + w_far);
    vec3 near_sum = vec3(0.0);
    float near_n = 0.0, far_n = 0.0;
    float b9[9];
    for (int i = 0; i < 9; ++i) {
        if (i == 4) continue;
        b9[i] = edge_brightness(c9[i]);
        if (w[i] > w_mid) {
            near_sum += c9[i];
            near_n += 1.0;
        } else {
            far_n += 1.0;
        }
    }
    if (near_n == 0.0 || far_n == 0.0) return EDGE_OWN;
    // The far layer's colour: its neighbour of median brightness (the darker middle one of an
    // even count; ties by position), not its mean. Next to a small bright highlight the far
    // neighbours are partly the highlight's other fringe pixels, a few of them a fifth of the
    // highlight or more: their mean came out as bright as the pixel itself, which then read as
    // no highlight light at all (scene A's HL15: fringe pixels of 2-11 over the star's 0.7 kept
    // its depth). The median is the background's as long as fewer than half are fringe.
    int rank = int(far_n - 1.0) / 2;
    vec3 c_far = vec3(0.0);
    for (int i = 0; i < 9; ++i) {
        if (i == 4 || w[i] > w_mid) continue;
        int below = 0;
        for (int j = 0; j < 9; ++j) {
            if (j == 4 || w[j] > w_mid) continue;
            below += (b9[j] < b9[i] || (b9[j] == b9[i] && j < i)) ? 1 : 0;
        }
        if (below == rank) c_far = c9[i];
    }
    vec3 c_near = near_sum / near_n;
    vec3 d = c_near - c_far;
    float dd = dot(d, d);
    if (dd <= 1.0e-12) return EDGE_OWN;
    // Read along the line from the far layer's colour to the near one's mean (alpha), the own
    // layer's pixels span a range: a near pixel inside it is explained by its own surface.
    bool own_near = w_p > w_mid;
    float lo = 1.0e30, hi = -1.0e30;
    for (int i = 0; i < 9; ++i) {
        if (i == 4 || (w[i] > w_mid) != own_near) continue;
        float a = dot(c9[i] - c_far, d) / dd;
        lo = min(lo, a);
        hi = max(hi, a);
    }
    float alpha_p = dot(c_p - c_far, d) / dd;
    if (own_near && alpha_p >= lo && alpha_p <= hi) return EDGE_OWN;
    float alpha = clamp(alpha_p, 0.0, 1.0);
    float near_light = alpha * edge_brightness(c_near), far_light = (1.0 - alpha) * edge_brightness(c_far);
    bool near = near_light > far_light;
    // The pixel keeps its own layer if it lies in the chosen one, or the other brings too little
    // of its light: the share of the light, not of the area (a highlight of 50 covering 19% of
    // a fringe pixel over a ball of 0.1 brings 99% of its light; judged by area it stayed with
    // the ball and its light was dragged along the ball's path).
    float other_share = (near ? near_light : far_light) / max(near_light + far_light, 1.0e-30);
    if (near == own_near || other_share < min_share) return EDGE_OWN;
    return near ? EDGE_NEAR : EDGE_FAR;
}

#endif
