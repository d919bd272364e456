// Vignetting's falloff at a pixel: the lens's relative-illumination table against image height
// when it has one (natural and optical vignetting as measured), else the cos^4 law of
// illumination (Kyaw 2013 eq 4.14, from eq 4.9) with the real field angle theta = atan(r / v), r
// the image height on the film and v the image distance. Used by vignette.comp, and by film.comp
// when the vignette runs in the film's dispatch. src/passes/lens/vignette.rs VignettePush::falloff is
// the twin. Needs height_table.glsl (and so the including shader's `table` buffer).
#ifndef REALCAM_VIGNETTE_GLSL
#define REALCAM_VIGNETTE_GLSL

// centre_px: the optical centre in pixel coordinates; `entries` heights of the table at word
// `base` of `table` (0: cos^4).
float vignette_falloff(ivec2 p, vec2 centre_px, float pixel_pitch_mm, float image_distance_mm, int base, int entries) {
    vec2 r_mm = (vec2(p) + 0.5 - centre_px) * pixel_pitch_mm;
    float t2 = dot(r_mm, r_mm) / (image_distance_mm * image_distance_mm);
    // cos^4(atan(t)) = 1 / (1 + t^2)^2, without trigonometry.
    float falloff = 1.0 / ((1.0 + t2) * (1.0 + t2));
    // The lens's table where it has one, in a loop of one trip or none: lavapipe evaluates both
    // sides of a conditional whatever the condition (and the lookup, given no table, read the
    // word before it), but leaves a loop that no lane is in.
    for (int once = 0; once < min(entries, 1); ++once) falloff = height_table_lookup_at(base, 1, entries, length(r_mm));
    return falloff;
}

#endif
