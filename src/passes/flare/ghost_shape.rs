//! The f32 twin of glsl/include/bezier_ghost.glsl: Walch 2017's measured-ghost primitive (ch. 6)
//! as the shaders evaluate it, its signed distance by a 12-step search over its Bezier sides and
//! eq 6.4's transfer of that distance into light. The fitted ghosts of the flare pass
//! (`fitted.rs`) and the tool shader `realcam flare` draws them with (src/tools/bezier_ghosts.rs)
//! share it; src/optics/bezier_ghost.rs has the exact f64 primitive it is tested against.

use crate::gpu::shaders::bezier_ghost::{BEZIER_COARSE, BEZIER_ROLL, BEZIER_SHAPE, BEZIER_STEPS, BEZIER_TRANSFER};

type V = [f32; 2];

fn add(a: V, b: V) -> V {
    [a[0] + b[0], a[1] + b[1]]
}

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot(a: V, b: V) -> f32 {
    a[0] * b[0] + a[1] * b[1]
}

fn at(p: &[V; 4], t: f32) -> V {
    let s = 1.0 - t;
    let w = [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t];
    [0, 1].map(|a| w[0] * p[0][a] + w[1] * p[1][a] + w[2] * p[2][a] + w[3] * p[3][a])
}

fn tangent(p: &[V; 4], t: f32) -> V {
    let s = 1.0 - t;
    let w = [3.0 * s * s, 6.0 * s * t, 3.0 * t * t];
    [0, 1].map(|a| w[0] * (p[1][a] - p[0][a]) + w[1] * (p[2][a] - p[1][a]) + w[2] * (p[3][a] - p[2][a]))
}

/// The twin of glsl/include/bezier_ghost.glsl's `bezier_side_distance`: the distance from the
/// origin to one side (control points relative to the query point) and eq 6.3's sign there.
pub fn side_distance(p: &[V; 4]) -> (f32, f32) {
    let slope = |t: f32| dot(at(p, t), tangent(p, t));
    let (mut best_t, mut best) = (0.0f32, 3.4e38f32);
    for k in 0..=BEZIER_COARSE {
        let t = k as f32 / BEZIER_COARSE as f32;
        let c = at(p, t);
        let d = dot(c, c);
        if d < best {
            (best, best_t) = (d, t);
        }
    }
    let step = 1.0 / BEZIER_COARSE as f32;
    let (mut lo, mut hi) = ((best_t - step).max(0.0), (best_t + step).min(1.0));
    let (mut g_lo, mut g_hi) = (slope(lo), slope(hi));
    for _ in 0..BEZIER_STEPS {
        let m = 0.5 * (lo + hi);
        let g = slope(m);
        if g > 0.0 {
            (hi, g_hi) = (m, g);
        } else {
            (lo, g_lo) = (m, g);
        }
    }
    let t = if g_lo < 0.0 && g_hi > 0.0 {
        lo + (hi - lo) * g_lo / (g_lo - g_hi)
    } else if g_lo >= 0.0 {
        lo
    } else {
        hi
    };
    let b = at(p, t);
    let mut tan = tangent(p, t);
    let chord = sub(p[3], p[0]);
    if dot(tan, tan).sqrt() <= 1e-6 * (dot(chord, chord).sqrt() + 1e-30) {
        tan = if t < 0.5 { sub(p[2], p[0]) } else { sub(p[3], p[1]) };
    }
    let sign = if dot([-tan[1], tan[0]], b) >= 0.0 { 1.0 } else { -1.0 };
    (dot(b, b).sqrt(), sign)
}

/// The 12-step search's signed distance (f32, > 0 inside) from `q` to the border of the
/// primitive of shape words `shape` (centre x y, height, left, right, left and right control).
pub fn search_signed_distance(shape: &[f32], q: V) -> f32 {
    let m = sub([shape[0], shape[1]], q);
    let (h, l, r, cl, cr) = (shape[2], shape[3], shape[4], shape[5], shape[6]);
    let (top, bottom, left, right) = (add(m, [0.0, -h]), add(m, [0.0, h]), add(m, [-l, 0.0]), add(m, [r, 0.0]));
    let sides = [
        [top, add(m, [-cl * l, -h]), add(m, [-l, -cl * h]), left],
        [left, add(m, [-l, cl * h]), add(m, [-cl * l, h]), bottom],
        [bottom, add(m, [cr * r, h]), add(m, [r, cr * h]), right],
        [right, add(m, [r, -cr * h]), add(m, [cr * r, -h]), top],
    ];
    let mut best = side_distance(&sides[0]);
    for s in &sides[1..] {
        let d = side_distance(s);
        if d.0 < best.0 {
            best = d;
        }
    }
    best.0 * best.1
}

/// The twin of glsl/include/bezier_ghost.glsl's `bezier_transfer` (eq 6.4 in f32).
pub fn transfer(d: f32, t: &[f32]) -> f32 {
    if d.is_nan() {
        return 0.0;
    }
    let out = d < 0.0;
    let f = if out { t[3] } else { t[2] };
    let e = (if out { t[5] } else { t[4] }).max(1e-6);
    let w = if f > 0.0 {
        (d.abs() / f).min(1.0).powf(e)
    } else if d == 0.0 {
        0.0
    } else {
        1.0
    };
    let target = if out { 0.0 } else { t[1] };
    t[0] + (target - t[0]) * w.clamp(0.0, 1.0)
}

/// The light of the primitive of words `w` at pixel centre `q` (before its colour).
pub fn primitive_light(w: &[f32], q: V) -> f32 {
    let r = BEZIER_ROLL as usize;
    let (pivot, c, s) = ([w[r + 2], w[r + 3]], w[r], w[r + 1]);
    let o = sub(q, pivot);
    let local = add(pivot, [c * o[0] + s * o[1], -s * o[0] + c * o[1]]);
    let d = search_signed_distance(&w[BEZIER_SHAPE as usize..][..7], local);
    transfer(d, &w[BEZIER_TRANSFER as usize..][..6])
}
