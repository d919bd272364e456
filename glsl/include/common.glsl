// Shared helpers for every realcam compute shader.
#ifndef REALCAM_COMMON_GLSL
#define REALCAM_COMMON_GLSL

#define TILE_SIZE 16
#define PI 3.14159265358979323846

bool outside(ivec2 p, ivec2 size) {
    return any(lessThan(p, ivec2(0))) || any(greaterThanEqual(p, size));
}

// Replace NaN and Inf with 0 and clamp the rest to a finite range, so one bad input pixel can
// never spread through a blur.
vec4 finite_or_zero(vec4 v) {
    bvec4 bad = bvec4(isnan(v.x) || isinf(v.x), isnan(v.y) || isinf(v.y),
                      isnan(v.z) || isinf(v.z), isnan(v.w) || isinf(v.w));
    return clamp(mix(v, vec4(0.0), bad), vec4(-3.0e38), vec4(3.0e38));
}

#endif
