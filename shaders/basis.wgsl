//! basis.wgsl: the Bernstein basis with its first and second derivatives, written once and
//! spliced into the shaders that evaluate patches at the line `// @include basis.wgsl`.
//!
//! Mirrored by src/eval/cpu/basis.rs. The includer declares `const NMAX: u32` (one more than
//! the highest degree it evaluates); WGSL module-scope declarations may come in any order.

// The degree-n Bernstein polynomials at t, n <= NMAX - 1 (the triangular recurrence of
// bezier::bernstein).
fn bernstein(n: u32, t: f32) -> array<f32, NMAX> {
    var out: array<f32, NMAX>;
    out[0] = 1.0;
    let s = 1.0 - t;
    for (var j = 1u; j < NMAX; j++) { // @unroll
        if (j <= n) {
            var saved = 0.0;
            for (var k = 0u; k < j; k++) { // @unroll
                let tmp = out[k];
                out[k] = fma(s, tmp, saved);
                saved = t * tmp;
            }
            out[j] = saved;
        }
    }
    return out;
}

// Bernstein values with first and second derivatives.
struct Basis {
    b: array<f32, NMAX>,
    d1: array<f32, NMAX>,
    d2: array<f32, NMAX>,
}

// The degree-n basis at t with its derivatives (paper eq. 2 applied once and twice), taken
// from levels n - 1 and n - 2 of the same recurrence.
fn basis(n: u32, t: f32) -> Basis {
    var lvl: array<f32, NMAX>;
    var low1: array<f32, NMAX>;
    var low2: array<f32, NMAX>;
    lvl[0] = 1.0;
    let s = 1.0 - t;
    for (var j = 1u; j < NMAX; j++) { // @unroll
        if (j <= n) {
            if (j + 1u == n) {
                low2 = lvl;
            }
            if (j == n) {
                low1 = lvl;
            }
            var saved = 0.0;
            for (var k = 0u; k < j; k++) { // @unroll
                let tmp = lvl[k];
                lvl[k] = fma(s, tmp, saved);
                saved = t * tmp;
            }
            lvl[j] = saved;
        }
    }
    var out: Basis;
    out.b = lvl;
    let nf = f32(n);
    let nn = nf * (nf - 1.0);
    // low1[i - 1], low2[i - 2] and low2[i - 1], zero before the start.
    var l1 = 0.0;
    var l2a = 0.0;
    var l2b = 0.0;
    for (var i = 0u; i < NMAX; i++) { // @unroll
        if (i <= n) {
            out.d1[i] = nf * (l1 - low1[i]);
            out.d2[i] = nn * ((l2a - 2.0 * l2b) + low2[i]);
            l1 = low1[i];
            l2a = l2b;
            l2b = low2[i];
        }
    }
    return out;
}
