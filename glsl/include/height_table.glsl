// Tables against image height in a storage buffer named `table` (declared by the including
// shader): n heights in mm, increasing, then columns of n values each. Linear interpolation;
// the end values continue beyond the table. src/passes/mod.rs `height_table_lookup` is the twin.
#ifndef REALCAM_HEIGHT_TABLE_GLSL
#define REALCAM_HEIGHT_TABLE_GLSL

// The table starting at word `base` of the buffer (a shader whose buffer holds another table
// first: film's curve, then the vignette's relative illumination).
float height_table_lookup_at(int base, int column, int n, float h_mm) {
    if (h_mm <= table[base]) return table[base + column * n];
    for (int i = 1; i < n; ++i) {
        if (h_mm <= table[base + i]) {
            float t = (h_mm - table[base + i - 1]) / (table[base + i] - table[base + i - 1]);
            return mix(table[base + column * n + i - 1], table[base + column * n + i], t);
        }
    }
    return table[base + column * n + n - 1];
}

float height_table_lookup(int column, int n, float h_mm) { return height_table_lookup_at(0, column, n, h_mm); }

#endif
