// Tables against image height in a storage buffer named `table` (declared by the including
// shader): n heights in mm, increasing, then columns of n values each. Linear interpolation;
// the end values continue beyond the table. src/passes/mod.rs `height_table_lookup` is the twin.
#ifndef REALCAM_HEIGHT_TABLE_GLSL
#define REALCAM_HEIGHT_TABLE_GLSL

float height_table_lookup(int column, int n, float h_mm) {
    if (h_mm <= table[0]) return table[column * n];
    for (int i = 1; i < n; ++i) {
        if (h_mm <= table[i]) {
            float t = (h_mm - table[i - 1]) / (table[i] - table[i - 1]);
            return mix(table[column * n + i - 1], table[column * n + i], t);
        }
    }
    return table[column * n + n - 1];
}

#endif
