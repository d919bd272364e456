// The aperture's image: an n-bladed iris (regular polygon, corners on the circle of radius r)
// with rotation and blade curvature, or a circle when blades < 3.
#ifndef REALCAM_APERTURE_GLSL
#define REALCAM_APERTURE_GLSL
#include "common.glsl"

// Part of every bokeh pass's push constants (src/passes/dof/aperture.rs mirrors it: 4-byte fields).
struct Aperture {
    int blades;            // < 3: circular
    float rotation;        // radians; 0 puts a corner straight up (y up), as Blender/Cycles does
    float curvature;       // 0: straight blades, 1: circular
    float sa_amount;       // spherical aberration: > 0 under-corrected, < 0 over-corrected, 0 uniform
    float sa_max_coc_px;   // the CoC at which the aberration reaches its full amount
    float centre_x_px;     // optical centre, in the shader's pixel units
    float centre_y_px;
    float cats_eye_per_px; // cat's-eye amount / distance from the centre to the farthest corner
    float sa_lsa_coc_px;   // traced spherical aberration: the rim's focus shift as a CoC; 0: sa_amount
    float shape_b;         // mix(cos(pi/n), 1, curvature): the polygon's edge at sdf = g(o) - r shape_b
    float area_factor;     // the aperture image's area over r^2
    int shape_radius;      // the shape table covers offsets with |x|, |y| <= this; 0: no table
};

// Specialization constants (src/passes/dof/aperture.rs `Specialization`): a pass whose lens needs
// neither sets them false and its pipeline is compiled without those paths. Lavapipe runs both
// sides of every branch, so a path switched off only at run time would still cost its time.
// APERTURE_GENERAL: the user's aperture image, the cat's eye, or offsets beyond the shape
// table may occur (false: every weight comes from the shape table). APERTURE_ABERRATION:
// spherical aberration may be non-zero (false: uniform discs).
layout(constant_id = 0) const bool APERTURE_GENERAL = true;
layout(constant_id = 1) const bool APERTURE_ABERRATION = true;

// The user's aperture image (src/model/aperture.rs): [size, mean, size*size values], size 0 when
// none. Each shader that includes this file defines APERTURE_MASK_BINDING.
layout(binding = APERTURE_MASK_BINDING, std430) readonly buffer ApertureMask { float aperture_mask[]; };

// The aperture's shape at integer offsets (src/passes/dof/aperture.rs shape_table), so gathers and
// sprites need no atan per tap: g(o) = |o| mix(cos(phi), 1, curvature), phi the angle of o from
// the nearest blade's edge normal; the signed distance to the edge of the image of
// circumradius r is g(o) - r shape_b. Texel (o + shape_radius) holds g(o); each shader that
// includes this file defines APERTURE_SHAPE_BINDING.
layout(binding = APERTURE_SHAPE_BINDING, r32f) uniform readonly image2D aperture_shape;

float mask_texel(ivec2 i, int n) {
    if (any(lessThan(i, ivec2(0))) || any(greaterThanEqual(i, ivec2(n)))) return 0.0;
    return aperture_mask[2 + i.y * n + i.x];
}

// The mask, bilinear, at uv in [-1, 1]^2 (the CoC's circumscribed square, y down).
float mask_value(vec2 uv) {
    int n = int(aperture_mask[0]);
    vec2 t = (uv * 0.5 + 0.5) * float(n) - 0.5;
    ivec2 i = ivec2(floor(t));
    vec2 f = t - vec2(i);
    return mix(mix(mask_texel(i, n), mask_texel(i + ivec2(1, 0), n), f.x),
               mix(mask_texel(i + ivec2(0, 1), n), mask_texel(i + ivec2(1, 1), n), f.x), f.y);
}

// Spherical aberration from the ray model of src/optics/spherical.rs (Kyaw 2013 sec 6.3.1,
// appendix 11.2-11.3): s grows with the CoC, flips sign in front of the focus plane.
#define SA_MAX_STRENGTH 0.3
float sa_strength(float coc_px, Aperture ap) {
    // Traced (src/optics/spherical.rs strength_traced): s = -LSA / defocus, both as CoC.
    if (ap.sa_lsa_coc_px != 0.0) {
        return coc_px == 0.0 ? 0.0 : clamp(ap.sa_lsa_coc_px / coc_px, -SA_MAX_STRENGTH, SA_MAX_STRENGTH);
    }
    float sa = clamp(ap.sa_amount * abs(coc_px) / max(ap.sa_max_coc_px, 1e-9), -1.0, 1.0);
    return (coc_px < 0.0 ? -sa : sa) * SA_MAX_STRENGTH;
}

// Relative intensity at normalised film radius r of a disk with strength s (mean 1): the pupil
// zone rho landing at r solves rho (1 + s rho^2) = (1 + s) r; I = (1+s)^2 / ((1+s rho^2)(1+3 s rho^2)).
// Newton steps from rho = r, as few as leave I within f32's resolution of the f64 root
// (src/optics/spherical.rs pupil_zone): four over the whole range of s (|s| <= SA_MAX_STRENGTH;
// 1.1e-5 relative at worst, at s = -0.3, the same as eight steps), two where |s| <= 0.1 (3.7e-7;
// the default lens's |s| is at most 0.09). Each step is a division per tap: eight steps cost
// lavapipe a quarter of the tiled depth of field, and the two steps take another 6 ms off a
// 1280x720 frame. sa_newton_steps_reach_the_f64_root (src/passes/dof/aperture.rs) checks both counts.
#define SA_NEWTON_STEPS 4
#define SA_NEWTON_STEPS_WEAK 2
float sa_intensity(float r_norm, float s) {
    if (s == 0.0) return 1.0;
    float r = clamp(r_norm, 0.0, 1.0);
    float rho = r;
    int steps = abs(s) <= 0.1 ? SA_NEWTON_STEPS_WEAK : SA_NEWTON_STEPS;
    for (int i = 0; i < steps; ++i) {
        float f = rho + s * rho * rho * rho - (1.0 + s) * r;
        rho = clamp(rho - f / (1.0 + 3.0 * s * rho * rho), 0.0, 1.0);
    }
    return (1.0 + s) * (1.0 + s) / ((1.0 + s * rho * rho) * (1.0 + 3.0 * s * rho * rho));
}

// Signed distance in pixels from offset o (x right, y DOWN, image convention) to the edge of the
// aperture image of circumradius r: negative inside.
float aperture_sdf(vec2 o, float r, Aperture ap) {
    float len = length(o);
    float d_circle = len - r;
    if (ap.blades < 3 || ap.curvature >= 1.0) return d_circle;
    float sector = 2.0 * PI / float(ap.blades);
    // Angle in the y-up frame, measured from the direction of the first edge's normal, which
    // lies half a sector from the first corner (at 90 degrees + rotation).
    float phi = atan(-o.y, o.x) - (0.5 * PI + ap.rotation + 0.5 * sector);
    // Fold into the nearest edge's sector: [-sector/2, sector/2).
    phi = phi - sector * floor(phi / sector + 0.5);
    float apothem = r * cos(0.5 * sector);
    float d_poly = len * cos(phi) - apothem;
    return mix(d_poly, d_circle, ap.curvature);
}

// Area of the aperture image of circumradius r, in px^2.
float aperture_area(float r, Aperture ap) {
    float circle = PI * r * r;
    if (ap.blades < 3) return circle;
    float n = float(ap.blades);
    float polygon = 0.5 * n * r * r * sin(2.0 * PI / n);
    return mix(polygon, circle, ap.curvature);
}

// Fraction of the pixel at offset o covered by the aperture image (a linear ramp `ramp` px wide
// across the edge: antialiased, and exactly 1 for the centre pixel of a point-sized image).
float aperture_coverage_ramp(vec2 o, float r, Aperture ap, float ramp) {
    // Nothing beyond the circumscribed circle's ramp: the polygon's edge-line distance
    // underestimates the true distance near corners, which would leak light past them.
    float limit = r + 0.5 * ramp;
    if (dot(o, o) >= limit * limit) return 0.0;
    return clamp(0.5 - aperture_sdf(o, r, ap) / ramp, 0.0, 1.0);
}

float aperture_coverage(vec2 o, float r, Aperture ap) {
    return aperture_coverage_ramp(o, r, ap, 1.0);
}

// The weight a sample at image position sample_px (flip = -1 in front of the focus plane, where
// the aperture's image is inverted; o is already flipped) gives the pixel at offset o: coverage
// over area, energy spread over the CoC. With the cat's eye (optical vignetting), the aperture
// is clipped by a circle of the same radius shifted toward the image centre in proportion to the
// sample's distance from it; the area shrinks with the two circles' overlap, so the highlight
// keeps its energy while its shape narrows toward the corners.
float aperture_weight(vec2 o, float r, Aperture ap, vec2 sample_px, float flip, float ramp) {
    float cov, area;
    if (aperture_mask[0] > 0.0 && r > 1.0) {
        // The user's aperture image, turned by the rotation (counter-clockwise, y up).
        float c = cos(ap.rotation), s = sin(ap.rotation);
        vec2 up = vec2(o.x, -o.y);
        vec2 turned = vec2(c * up.x + s * up.y, -s * up.x + c * up.y);
        cov = mask_value(vec2(turned.x, -turned.y) / r);
        area = aperture_mask[1] * 4.0 * r * r;
    } else {
        // Points of a pixel or less show no shape: the polygon / circle.
        cov = aperture_coverage_ramp(o, r, ap, ramp);
        area = aperture_area(r, ap);
    }
    if (ap.cats_eye_per_px > 0.0 && cov > 0.0) {
        vec2 c = (vec2(ap.centre_x_px, ap.centre_y_px) - sample_px) * ap.cats_eye_per_px * r * flip;
        float d = min(length(c), 2.0 * r);
        cov = min(cov, clamp(0.5 - (length(o - c) - r) / ramp, 0.0, 1.0));
        // Overlap of two circles of radius r at distance d, relative to one circle.
        float h = 0.5 * d / max(r, 1e-6);
        float overlap = (2.0 * acos(h) - 2.0 * h * sqrt(max(1.0 - h * h, 0.0))) / PI;
        area *= max(overlap, 1e-3);
    }
    return cov / area;
}

// aperture_weight for an integer offset o (already flipped) from the shape table: exact for a
// bladed or round aperture; the aperture image and the cat's eye take the general path.
float aperture_weight_at(ivec2 o, float r, Aperture ap, vec2 sample_px, float flip, float ramp) {
    bool in_table = all(lessThanEqual(abs(o), ivec2(ap.shape_radius)));
    if (APERTURE_GENERAL) {
        bool table = ap.shape_radius > 0 && ap.cats_eye_per_px <= 0.0 && !(aperture_mask[0] > 0.0 && r > 1.0) && in_table;
        if (!table) return aperture_weight(vec2(o), r, ap, sample_px, flip, ramp);
    } else if (!in_table) {
        return 0.0;  // the pass sized the table to the largest reach: nothing lies beyond it
    }
    float limit = r + 0.5 * ramp;
    if (float(o.x * o.x + o.y * o.y) >= limit * limit) return 0.0;
    float g = imageLoad(aperture_shape, o + ivec2(ap.shape_radius)).r;
    float cov = clamp(0.5 - (g - r * ap.shape_b) / ramp, 0.0, 1.0);
    return cov / (ap.area_factor * r * r);
}

// The radius of the disc of offsets at which samples reaching at most reach_px can weigh (the
// gathers' taps): an aperture's image ends half a pixel beyond its reach (the coverage ramp;
// the cat's eye only cuts it), the user's aperture image, bilinear over its square, up to the
// reach + 1 that the gathers test. Every reach is at least 0.5.
float tap_disc_px(float reach_px) {
    bool image = APERTURE_GENERAL && aperture_mask[0] > 0.0;
    return max(reach_px, 0.5) + (image ? 1.0 : 0.5);
}

// Spherical aberration's intensity for a sample of signed CoC coc_q at offset o (1 without it).
float sa_weight(vec2 o, float radius_q, float coc_q, Aperture ap) {
    if (!APERTURE_ABERRATION || (ap.sa_amount == 0.0 && ap.sa_lsa_coc_px == 0.0)) return 1.0;
    return sa_intensity(length(o) / radius_q, sa_strength(coc_q, ap));
}

#endif
