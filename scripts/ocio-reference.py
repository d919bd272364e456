#!/usr/bin/env python3
"""OpenColorIO's own numbers for tests/ocio.rs, computed once and committed there.

    python3 -m venv /tmp/ociovenv && /tmp/ociovenv/bin/pip install opencolorio
    /tmp/ociovenv/bin/python scripts/ocio-reference.py

Prints, for a few ACEScg colours, the ACES cg config v4.0.0's conversion to
"Linear Rec.709 (sRGB)" (cs) and its sRGB display's ACES 2.0 SDR view (dv).
"""
import PyOpenColorIO as ocio

CONFIG = "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5"
COLOURS = [(0.18, 0.18, 0.18), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0),
           (1.0, 1.0, 1.0), (0.5, 0.25, 0.1), (4.0, 2.0, 1.0)]

cfg = ocio.Config.CreateFromFile(CONFIG)
cs = cfg.getProcessor("ACEScg", "Linear Rec.709 (sRGB)").getDefaultCPUProcessor()
dv = cfg.getProcessor("ACEScg", "sRGB - Display", "ACES 2.0 - SDR 100 nits (Rec.709)",
                      ocio.TRANSFORM_DIR_FORWARD).getDefaultCPUProcessor()
print("// PyOpenColorIO", ocio.__version__, CONFIG)
for name, proc in (("cs", cs), ("dv", dv)):
    for c in COLOURS:
        out = proc.applyRGB(list(c))
        print(f"{name}: ([{c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}], "
              f"[{out[0]:.7f}, {out[1]:.7f}, {out[2]:.7f}]),")
