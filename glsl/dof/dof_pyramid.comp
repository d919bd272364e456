#version 450
// Tiled depth of field: level L of the pyramid from level L - 1 (L = 2 .. 4), the same
// premultiplied averages as level 1 (dof_downsample.comp): colour sum / 4, the nearest CoC of
// the texels that hold blurring pixels, weight sum / 4. Texels beyond the finer level's edge
// count as empty.
#include "common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_fine;
layout(binding = 1, rg32f) uniform readonly image2D coc_fine;
layout(binding = 2, rgba32f) uniform writeonly image2D color_coarse;
layout(binding = 3, rg32f) uniform writeonly image2D coc_coarse;

layout(push_constant) uniform Push {
    ivec2 fine_size;
    ivec2 coarse_size;
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.coarse_size)) return;
    vec4 sum = vec4(0.0);
    float weight = 0.0, coc_near = 1e30;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 q = p * 2 + ivec2(i, j);
            if (outside(q, pc.fine_size)) continue;
            vec2 cw = imageLoad(coc_fine, q).rg;
            sum += imageLoad(color_fine, q);
            weight += cw.y;
            if (cw.y > 0.0) coc_near = min(coc_near, cw.x);
        }
    }
    imageStore(color_coarse, p, 0.25 * sum);
    imageStore(coc_coarse, p, vec4(weight > 0.0 ? coc_near : 0.0, 0.25 * weight, 0.0, 0.0));
}
