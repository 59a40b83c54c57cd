//! Frustum culling of a query's answer (spec § Frustum culling): the camera's six clip planes,
//! taken from its view-projection matrix or given directly, and the conservative test that
//! drops a patch whose bounding sphere lies wholly outside one of them, so that an embedder
//! gets the set to draw in one call.
//!
//! The test is Gribb–Hartmann plane extraction and the usual sphere–plane test, in binary32
//! with an error allowance, so that it never drops a sphere any point of which lies in the
//! frustum: a plane `(a, b, c, d)` is scaled by a power of two (exactly) until
//! `max(|a|, |b|, |c|)` is in `[1, 2)`, `n = √(a² + b² + c²)`, and a sphere `(x, y, z, r)` is
//! outside it iff
//!
//! ```text
//! t = (((a·x + b·y) + c·z) + d) + r·n  <  −(s · 2⁻¹⁸) − 2⁻¹²⁶,
//! s = (((|a·x| + |b·y|) + |c·z|) + |d|) + r·n,
//! ```
//!
//! every operation a binary32 one, in that order. Why it is conservative: `t` is the plane's
//! value at the sphere's farthest point on its positive side (exact arithmetic gives
//! `max over the sphere of a·x + b·y + c·z + d`); its computed value differs from the exact one
//! by at most about 6 roundings of terms bounded by `s` (γ₆·s), the norm's by 3 more, and the
//! plane's own rounding from the matrix (one addition per coefficient) by `s·2⁻²⁴·√3`: under
//! `12·2⁻²⁴·s`, far inside the `2⁻¹⁸·s = 64·2⁻²⁴·s` allowed. `2⁻¹²⁶` covers products that
//! underflow. A non-finite value anywhere makes `t` or `s` infinite or NaN, and the comparison
//! then keeps the sphere. The test is exact otherwise (no sphere is dropped that the rule
//! keeps), so every reader that follows the spec returns the same sets.
//!
//! Cost: [`Frustum::keeps`] is 6 × (4 multiplications, 8 additions); [`Frustum::cull`] decodes
//! each answer patch's record. [`super::Expanded::query_in_frustum`] instead reads the bounds
//! that [`super::Pvis::expand`] stored (struct of arrays, 64 patches a block, with one
//! bounding sphere per block and one for the whole model): a plane the model's sphere lies
//! inside is never tested, a block's sphere wholly inside or outside settles its 64 patches at
//! once, so the common case costs a few sphere tests. These shortcuts fire only where the
//! per-patch rule gives the same answer for every patch (see [`Shortcut`]), so all modes return
//! the same bits.

use super::query::Patches;
use super::{PatchInfo, Pvis};

/// How clip-space depth is bounded: OpenGL's `−w ≤ z ≤ w`, or the `0 ≤ z ≤ w` of Direct3D,
/// Vulkan, Metal and wgpu.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthRange {
    /// `−w ≤ z ≤ w` (OpenGL, WebGL).
    NegativeOneToOne,
    /// `0 ≤ z ≤ w` (Direct3D, Vulkan, Metal, wgpu, WebGPU).
    ZeroToOne,
}

/// The relative error allowance `2⁻¹⁸` of the test (see the module documentation).
const ALLOWANCE: f32 = 1.0 / (1u32 << 18) as f32;

/// The absolute allowance: the smallest normal binary32, more than all underflowed products.
const TINY: f32 = f32::MIN_POSITIVE;

/// One clip plane, scaled so that `max(|a|, |b|, |c|)` is in `[1, 2)`: inside is
/// `a·x + b·y + c·z + d ≥ 0`; `n` is `√(a² + b² + c²)` in binary32.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Plane {
    a: f32,
    b: f32,
    c: f32,
    d: f32,
    n: f32,
}

impl Plane {
    /// The plane `a·x + b·y + c·z + d ≥ 0`, scaled by a power of two: exact unless a
    /// coefficient scaled down lands among the subnormals or `d` scaled up overflows (spec
    /// § Frustum culling, Scaling).
    fn new([a, b, c, d]: [f32; 4]) -> Plane {
        let largest = a.abs().max(b.abs()).max(c.abs());
        // The biased exponent of a normal `largest`, `m · 2^(e − 127)` with `m` in [1, 2).
        let e = largest.to_bits() >> 23;
        let [a, b, c, d] = if (1..=253).contains(&e) && largest.is_finite() {
            // Times `2^(127 − e)`, itself a normal binary32: one rounding, as `scalbnf`.
            let factor = f32::from_bits((254 - e) << 23);
            [a, b, c, d].map(|v| v * factor)
        } else if largest > 0.0 && largest.is_finite() {
            // Subnormal or huge: `largest = m · 2^k` with `m` in [0.5, 1), times `2^(1 − k)`.
            let (_, e) = libm::frexpf(largest);
            [a, b, c, d].map(|v| libm::scalbnf(v, 1 - e))
        } else {
            [a, b, c, d]
        };
        Plane {
            a,
            b,
            c,
            d,
            n: libm::sqrtf((a * a + b * b) + c * c),
        }
    }

    /// `(t, s)` of the module documentation for the sphere `(x, y, z, r)`, with `r·n` signed
    /// by `sign` (`1` for the farthest point on the positive side, `−1` for the nearest).
    #[inline(always)]
    fn terms(&self, x: f32, y: f32, z: f32, r: f32, sign: f32) -> (f32, f32) {
        let (px, py, pz, rn) = (self.a * x, self.b * y, self.c * z, r * self.n);
        let t = (((px + py) + pz) + self.d) + sign * rn;
        let s = (((px.abs() + py.abs()) + pz.abs()) + self.d.abs()) + rn;
        (t, s)
    }

    /// The normative test: whether the sphere lies wholly outside this plane.
    #[inline(always)]
    fn outside(&self, x: f32, y: f32, z: f32, r: f32) -> bool {
        let (t, s) = self.terms(x, y, z, r, 1.0);
        t < -(s * ALLOWANCE) - TINY
    }

    /// How a sphere that contains patch spheres settles them for this plane (see
    /// [`Shortcut`]).
    #[inline(always)]
    fn shortcut(&self, x: f32, y: f32, z: f32, r: f32) -> Shortcut {
        let (inner, s) = self.terms(x, y, z, r, -1.0);
        // Exactly, `inner ≥ computed − s·2⁻¹⁸ > 0`: the whole sphere is strictly inside, so
        // every contained patch has an exact `t ≥ 0` and a computed one above the threshold.
        if inner > s * ALLOWANCE + TINY {
            return Shortcut::AllInside;
        }
        // Exactly, `t ≤ computed + s·2⁻¹⁸`, and a contained patch has `t_p ≤ t` and
        // `s_p ≤ s + 2·r·n` (its centre is within `r` of this one's); so `t_p` plus its own
        // rounding stays below the patch's threshold with room to spare.
        let (outer, _) = self.terms(x, y, z, r, 1.0);
        let bound = s + 2.0 * (r * self.n);
        if outer < -4.0 * (bound * ALLOWANCE) - 4.0 * TINY {
            return Shortcut::AllOutside;
        }
        Shortcut::Mixed
    }
}

/// What a sphere containing many patch spheres says about them for one plane. Each variant
/// holds only where the per-patch test ([`Plane::outside`]) says the same of every patch in
/// it, with margins larger than its rounding, so the shortcuts never change an answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shortcut {
    /// Every contained patch is kept by this plane.
    AllInside,
    /// Every contained patch is dropped by this plane.
    AllOutside,
    /// Test the patches.
    Mixed,
}

/// A camera's view frustum as six clip planes, for [`Frustum::keeps`] and the
/// `query_in_frustum` queries. `Copy`, 120 bytes, built in a few dozen operations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    planes: [Plane; 6],
}

impl Frustum {
    /// The frustum of a view-projection matrix `m` (model space to clip space), column-major
    /// as OpenGL, WebGPU and glam store it (`m[4·col + row]`), for clip coordinates
    /// `(x, y, z, w) = m · (px, py, pz, 1)` with `−w ≤ x ≤ w`, `−w ≤ y ≤ w` and `depth`'s
    /// range of `z`. Each plane is a row sum or difference in binary32 (spec § Frustum
    /// culling): left `r₃ + r₀`, right `r₃ − r₀`, bottom `r₃ + r₁`, top `r₃ − r₁`, near
    /// `r₃ + r₂` (or `r₂` for [`DepthRange::ZeroToOne`]), far `r₃ − r₂`. An infinite far
    /// plane gives `(0, 0, 0, d ≥ 0)`, which drops nothing.
    pub fn from_view_projection(m: &[f32; 16], depth: DepthRange) -> Frustum {
        let row = |i: usize| [m[i], m[4 + i], m[8 + i], m[12 + i]];
        let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
        let add = |p: [f32; 4], q: [f32; 4]| [0, 1, 2, 3].map(|k| p[k] + q[k]);
        let sub = |p: [f32; 4], q: [f32; 4]| [0, 1, 2, 3].map(|k| p[k] - q[k]);
        let near = match depth {
            DepthRange::NegativeOneToOne => add(r3, r2),
            DepthRange::ZeroToOne => r2,
        };
        Frustum::from_planes([
            add(r3, r0),
            sub(r3, r0),
            add(r3, r1),
            sub(r3, r1),
            near,
            sub(r3, r2),
        ])
    }

    /// The frustum bounded by six planes `[a, b, c, d]`, each keeping the points with
    /// `a·x + b·y + c·z + d ≥ 0` (model space; any scale, any order). `[0, 0, 0, 1]` is a
    /// plane that drops nothing, for frusta with fewer sides.
    pub fn from_planes(planes: [[f32; 4]; 6]) -> Frustum {
        Frustum {
            planes: planes.map(Plane::new),
        }
    }

    /// The six planes as used by the test, each scaled by a power of two so that its largest
    /// `|a|, |b|, |c|` is in `[1, 2)`.
    pub fn planes(&self) -> [[f32; 4]; 6] {
        self.planes.map(|p| [p.a, p.b, p.c, p.d])
    }

    /// Whether a sphere may show inside the frustum: false only if it lies wholly outside one
    /// plane by the test of spec § Frustum culling. Never false for a sphere any point of
    /// which is inside; NaN anywhere keeps it.
    pub fn keeps(&self, center: [f32; 3], radius: f32) -> bool {
        let [x, y, z] = center;
        !self.planes.iter().any(|p| p.outside(x, y, z, radius))
    }

    /// Whether patch record `info` is kept: [`Frustum::keeps`] of its bounding sphere.
    pub fn keeps_patch(&self, info: &PatchInfo) -> bool {
        self.keeps(info.center, info.radius)
    }

    /// Clears in `bits` (a row in the reader's layout, e.g. a query's answer copied out) the
    /// patches of `pvis` the frustum drops. Cost: one record decode and test per set bit.
    ///
    /// # Panics
    /// If a bit is set for a patch past `pvis.patch_count()`.
    pub fn cull(&self, pvis: &Pvis<'_>, bits: &mut [u64]) {
        for w in 0..bits.len() {
            let mut dropped = 0u64;
            for p in Patches::of_bits(&bits[w..w + 1]) {
                if !self.keeps_patch(&pvis.patch(w as u32 * 64 + p)) {
                    dropped |= 1 << p;
                }
            }
            bits[w] &= !dropped;
        }
    }
}

/// Words of the bounds [`super::Pvis::expand`] stores for [`Bounds`]: the model's sphere, then
/// per block of 64 patches its sphere and 4 × 64 lanes (`x`, `y`, `z`, `r`).
pub(super) const fn bounds_words(row_words: usize) -> usize {
    SPHERE_WORDS + BLOCK_WORDS * row_words
}

/// Words of one sphere: `[x | y]`, `[z | r]` (`f32` bits, low half first).
const SPHERE_WORDS: usize = 2;

/// Words of one block's lanes: 64 `f32`s of each of `x`, `y`, `z`, `r`.
const LANE_WORDS: usize = 4 * 32;

/// Words of one block: its sphere, then its lanes.
const BLOCK_WORDS: usize = SPHERE_WORDS + LANE_WORDS;

/// Writes the bounds of `pvis`'s patches into `out` ([`bounds_words`] words).
pub(super) fn build_bounds(pvis: &Pvis<'_>, out: &mut [u64]) {
    out.fill(0);
    let count = pvis.patch_count();
    let (model, blocks) = out.split_at_mut(SPHERE_WORDS);
    let all = enclosing(|f| (0..count).for_each(|p| f(pvis.patch(p))));
    write_sphere(model, all);
    for (b, block) in blocks.chunks_exact_mut(BLOCK_WORDS).enumerate() {
        let first = b as u32 * 64;
        let members = first..count.min(first + 64);
        let sphere = enclosing(|f| members.clone().for_each(|p| f(pvis.patch(p))));
        let (head, lanes) = block.split_at_mut(SPHERE_WORDS);
        write_sphere(head, sphere);
        for p in members.clone() {
            let info = pvis.patch(p);
            let lane = (p - first) as usize;
            let values = [info.center[0], info.center[1], info.center[2], info.radius];
            for (k, v) in values.into_iter().enumerate() {
                lanes[32 * k + lane / 2] |= u64::from(v.to_bits()) << (32 * (lane % 2));
            }
        }
    }
}

/// A sphere containing every sphere `each` yields: centre at the middle of their bounding box,
/// radius the largest centre distance plus radius, widened by `2⁻²⁰` relative and `2⁻¹²⁶` to
/// cover its rounding (a few binary32 operations of relative error 2⁻²⁴ each). Non-finite
/// when the spheres are too large for binary32, which disables the shortcuts.
fn enclosing(each: impl Fn(&mut dyn FnMut(PatchInfo))) -> [f32; 4] {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    each(&mut |info| {
        for i in 0..3 {
            lo[i] = lo[i].min(info.center[i] - info.radius);
            hi[i] = hi[i].max(info.center[i] + info.radius);
        }
    });
    let c = [0, 1, 2].map(|i| lo[i] * 0.5 + hi[i] * 0.5);
    let mut r = 0.0f32;
    each(&mut |info| {
        let v = [0, 1, 2].map(|i| info.center[i] - c[i]);
        r = r.max(libm::sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + info.radius);
    });
    [
        c[0],
        c[1],
        c[2],
        r * (1.0 + 1.0 / (1u32 << 20) as f32) + TINY,
    ]
}

fn write_sphere(out: &mut [u64], s: [f32; 4]) {
    out[0] = u64::from(s[0].to_bits()) | u64::from(s[1].to_bits()) << 32;
    out[1] = u64::from(s[2].to_bits()) | u64::from(s[3].to_bits()) << 32;
}

fn read_sphere(words: &[u64]) -> [f32; 4] {
    let lo = |w: u64| f32::from_bits(w as u32);
    let hi = |w: u64| f32::from_bits((w >> 32) as u32);
    [lo(words[0]), hi(words[0]), lo(words[1]), hi(words[1])]
}

/// The patch bounds [`super::Pvis::expand`] stored, read by
/// [`super::Expanded::query_in_frustum`].
pub(super) struct Bounds<'t> {
    words: &'t [u64],
}

impl<'t> Bounds<'t> {
    /// The bounds at `words` (as [`build_bounds`] wrote them).
    pub(super) fn new(words: &'t [u64]) -> Bounds<'t> {
        Bounds { words }
    }

    /// Which of `frustum`'s planes the patches must be tested against, or `None` when the
    /// whole model lies inside every plane (the frustum drops nothing).
    pub(super) fn tests(&self, frustum: &Frustum) -> Option<Tests> {
        let [x, y, z, r] = read_sphere(&self.words[..SPHERE_WORDS]);
        let mut tests = Tests {
            planes: [0; 6],
            count: 0,
            nothing: false,
        };
        for (i, plane) in frustum.planes.iter().enumerate() {
            match plane.shortcut(x, y, z, r) {
                Shortcut::AllInside => {}
                Shortcut::AllOutside => tests.nothing = true,
                Shortcut::Mixed => {
                    tests.planes[tests.count] = i as u8;
                    tests.count += 1;
                }
            }
        }
        (tests.nothing || tests.count > 0).then_some(tests)
    }

    /// `bits`, word `w` of an answer, without the patches `frustum` drops.
    #[inline]
    pub(super) fn cull_word(&self, frustum: &Frustum, tests: &Tests, w: usize, bits: u64) -> u64 {
        if bits == 0 || tests.nothing {
            return 0;
        }
        let at = SPHERE_WORDS + w * BLOCK_WORDS;
        match self.words.get(at..at + BLOCK_WORDS) {
            Some(block) => bits & !dropped(frustum, tests.planes(), block, bits),
            None => bits,
        }
    }
}

/// The planes [`Bounds::cull_word`] tests: those the model's sphere straddles.
pub(super) struct Tests {
    planes: [u8; 6],
    count: usize,
    /// The model's sphere lies wholly outside a plane: the frustum drops every patch.
    nothing: bool,
}

impl Tests {
    fn planes(&self) -> &[u8] {
        &self.planes[..self.count]
    }
}

/// The lanes of `block` (64 patches, `bits` those of the answer) that `frustum`'s planes
/// `active` drop.
fn dropped(frustum: &Frustum, active: &[u8], block: &[u64], bits: u64) -> u64 {
    let [x, y, z, r] = read_sphere(&block[..SPHERE_WORDS]);
    let lanes = &block[SPHERE_WORDS..];
    let mut mask = 0u64;
    for &i in active {
        let plane = &frustum.planes[usize::from(i)];
        match plane.shortcut(x, y, z, r) {
            Shortcut::AllInside => {}
            Shortcut::AllOutside => return !0,
            Shortcut::Mixed => {
                mask |= lane_mask(plane, lanes) & bits;
                if mask == bits {
                    return mask;
                }
            }
        }
    }
    mask
}

/// The lanes a plane drops, by the per-patch test, 64 at a time.
#[inline(always)]
fn lane_mask(plane: &Plane, lanes: &[u64]) -> u64 {
    let (xs, rest) = lanes.split_at(32);
    let (ys, rest) = rest.split_at(32);
    let (zs, rs) = rest.split_at(32);
    let mut mask = 0u64;
    for k in 0..32 {
        let lo = |w: &[u64]| f32::from_bits(w[k] as u32);
        let hi = |w: &[u64]| f32::from_bits((w[k] >> 32) as u32);
        let even = plane.outside(lo(xs), lo(ys), lo(zs), lo(rs));
        let odd = plane.outside(hi(xs), hi(ys), hi(zs), hi(rs));
        mask |= (u64::from(even) | u64::from(odd) << 1) << (2 * k);
    }
    mask
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use proptest::prelude::*;
    use std::vec;
    use std::vec::Vec;

    /// Column-major `a · b` in binary64.
    fn mul(a: &[f64; 16], b: &[f64; 16]) -> [f64; 16] {
        core::array::from_fn(|i| {
            let (row, col) = (i % 4, i / 4);
            (0..4).map(|k| a[4 * k + row] * b[4 * col + k]).sum()
        })
    }

    /// A right-handed look-at view times a perspective projection (vertical `fov_deg`), for
    /// clip depth `depth`, column-major, rounded to binary32.
    fn view_projection(
        eye: [f64; 3],
        target: [f64; 3],
        fov_deg: f64,
        aspect: f64,
        near: f64,
        far: f64,
        depth: DepthRange,
    ) -> [f32; 16] {
        let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let norm = |a: [f64; 3]| {
            let l = dot(a, a).sqrt();
            [a[0] / l, a[1] / l, a[2] / l]
        };
        let f = norm(sub(target, eye));
        let up = if f[1].abs() > 0.999 {
            [0.0, 0.0, 1.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let s = norm(cross(f, up));
        let u = cross(s, f);
        let view = [
            s[0],
            u[0],
            -f[0],
            0.0,
            s[1],
            u[1],
            -f[1],
            0.0,
            s[2],
            u[2],
            -f[2],
            0.0,
            -dot(s, eye),
            -dot(u, eye),
            dot(f, eye),
            1.0,
        ];
        let g = 1.0 / (fov_deg.to_radians() / 2.0).tan();
        let (c, e) = match depth {
            DepthRange::NegativeOneToOne => {
                ((far + near) / (near - far), 2.0 * far * near / (near - far))
            }
            DepthRange::ZeroToOne => (far / (near - far), far * near / (near - far)),
        };
        let proj = [
            g / aspect,
            0.0,
            0.0,
            0.0,
            0.0,
            g,
            0.0,
            0.0,
            0.0,
            0.0,
            c,
            -1.0,
            0.0,
            0.0,
            e,
            0.0,
        ];
        mul(&proj, &view).map(|v| v as f32)
    }

    /// Whether `p` is inside the clip volume of `m`, exactly enough (binary64 products of
    /// binary32 entries), with a relative margin so that rounding cannot decide.
    fn clearly_inside(m: &[f32; 16], p: [f64; 3], depth: DepthRange) -> bool {
        let clip: [f64; 4] = core::array::from_fn(|i| {
            (0..3).map(|k| f64::from(m[4 * k + i]) * p[k]).sum::<f64>() + f64::from(m[12 + i])
        });
        let scale: f64 = (0..4)
            .map(|i| {
                (0..3)
                    .map(|k| (f64::from(m[4 * k + i]) * p[k]).abs())
                    .sum::<f64>()
                    + f64::from(m[12 + i]).abs()
            })
            .fold(0.0, f64::max);
        let eps = 1e-9 * scale;
        let w = clip[3];
        let lo = match depth {
            DepthRange::NegativeOneToOne => -w,
            DepthRange::ZeroToOne => 0.0,
        };
        clip[0] > -w + eps
            && clip[0] < w - eps
            && clip[1] > -w + eps
            && clip[1] < w - eps
            && clip[2] > lo + eps
            && clip[2] < w - eps
    }

    #[test]
    fn identity_planes_in_both_depth_conventions() {
        let mut id = [0.0f32; 16];
        for i in 0..4 {
            id[5 * i] = 1.0;
        }
        let gl = Frustum::from_view_projection(&id, DepthRange::NegativeOneToOne);
        let zo = Frustum::from_view_projection(&id, DepthRange::ZeroToOne);
        // Left, right, bottom, top, near, far of the unit cube (w = 1).
        assert_eq!(
            gl.planes(),
            [
                [1.0, 0.0, 0.0, 1.0],
                [-1.0, 0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0, 1.0],
                [0.0, -1.0, 0.0, 1.0],
                [0.0, 0.0, 1.0, 1.0],
                [0.0, 0.0, -1.0, 1.0],
            ]
        );
        assert_eq!(zo.planes()[4], [0.0, 0.0, 1.0, 0.0]);
        assert_eq!(zo.planes()[5], gl.planes()[5]);
        // A small sphere at z = -0.5 is inside GL's cube, outside 0 ≤ z.
        assert!(gl.keeps([0.0, 0.0, -0.5], 0.1));
        assert!(!zo.keeps([0.0, 0.0, -0.5], 0.1));
        // Touching counts as inside; a hair beyond the allowance does not.
        assert!(zo.keeps([0.0, 0.0, -0.1], 0.1));
        assert!(!zo.keeps([0.0, 0.0, -0.1001], 0.1));
        assert!(gl.keeps([1.5, 0.0, 0.0], 0.5));
        assert!(!gl.keeps([1.5, 0.0, 0.0], 0.49));
        for x in [-3.0, 3.0] {
            assert!(!gl.keeps([0.0, x, 0.0], 1.0));
            assert!(!gl.keeps([0.0, 0.0, x], 1.0));
        }
    }

    #[test]
    fn perspective_planes_in_both_depth_conventions() {
        for depth in [DepthRange::NegativeOneToOne, DepthRange::ZeroToOne] {
            // Looking down −Z from the origin, 90° vertical, aspect 2, near 1, far 100.
            let m = view_projection([0.0; 3], [0.0, 0.0, -1.0], 90.0, 2.0, 1.0, 100.0, depth);
            let f = Frustum::from_view_projection(&m, depth);
            let planes = f.planes();
            // The side planes' normals lean towards the view direction (−Z) by the half-angles.
            let n = |p: [f32; 4]| [p[0], p[1], p[2]];
            let unit = |v: [f32; 3]| {
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                v.map(|c| c / l)
            };
            let close = |a: [f32; 3], b: [f32; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-5);
            let s = 1.0 / 5f32.sqrt();
            assert!(close(unit(n(planes[0])), [s, 0.0, -2.0 * s]), "{planes:?}");
            assert!(close(unit(n(planes[1])), [-s, 0.0, -2.0 * s]));
            let h = core::f32::consts::FRAC_1_SQRT_2;
            assert!(close(unit(n(planes[2])), [0.0, h, -h]));
            assert!(close(unit(n(planes[3])), [0.0, -h, -h]));
            assert!(close(unit(n(planes[4])), [0.0, 0.0, -1.0]));
            assert!(close(unit(n(planes[5])), [0.0, 0.0, 1.0]));
            // Near at z = −1 and far at z = −100, in both conventions.
            assert!(f.keeps([0.0, 0.0, -0.95], 0.051));
            assert!(!f.keeps([0.0, 0.0, -0.9], 0.09));
            assert!(f.keeps([0.0, 0.0, -100.5], 0.51));
            assert!(!f.keeps([0.0, 0.0, -101.0], 0.9));
            // Behind the eye and beside the view.
            assert!(!f.keeps([0.0, 0.0, 5.0], 1.0));
            assert!(!f.keeps([30.0, 0.0, -10.0], 1.0));
            assert!(f.keeps([30.0, 0.0, -10.0], 12.0));
            assert!(!f.keeps([0.0, 30.0, -10.0], 10.0));
        }
    }

    #[test]
    fn non_finite_and_degenerate_planes_keep() {
        let f = Frustum::from_planes([[f32::NAN, 0.0, 0.0, 0.0]; 6]);
        assert!(f.keeps([1.0, 2.0, 3.0], 0.0));
        let f = Frustum::from_planes([[f32::INFINITY, 0.0, 0.0, -1.0]; 6]);
        assert!(f.keeps([-1.0, 2.0, 3.0], 0.0));
        let f = Frustum::from_view_projection(&[0.0; 16], DepthRange::NegativeOneToOne);
        assert!(f.keeps([1e30, -1e30, 0.0], 0.0));
        // A plane with a negative constant and no normal holds no point: everything goes.
        let f = Frustum::from_planes([[0.0, 0.0, 0.0, -1.0]; 6]);
        assert!(!f.keeps([0.0; 3], 1e30));
        assert!(Frustum::from_planes([[0.0, 0.0, 0.0, 1.0]; 6]).keeps([1e38; 3], 0.0));
        // Tiny and huge coefficients are scaled exactly: the same plane at any scale.
        for scale in [1e-40f32, 1e-30, 1.0, 1e30] {
            let f = Frustum::from_planes([[scale, 0.0, 0.0, -scale]; 6]);
            assert!(f.keeps([0.5, 0.0, 0.0], 0.5));
            assert!(!f.keeps([0.5, 0.0, 0.0], 0.49));
        }
    }

    proptest! {
        // About a third of the drawn cases are rejected (a point too near a plane to be
        // clearly inside, a radius that rounds below the distance): room for 10× that, so
        // that no seed runs out of rejects.
        #![proptest_config(ProptestConfig {
            max_global_rejects: 20_000,
            ..ProptestConfig::with_cases(2000)
        })]

        /// A sphere containing a point inside the frustum is never dropped: the point is drawn
        /// inside the frustum (in view space, then taken to model space), the sphere's centre
        /// anywhere within the radius of it.
        #[test]
        fn spheres_touching_the_frustum_are_kept(
            eye in prop::array::uniform3(-1e3f64..1e3),
            dir in prop::array::uniform3(-1.0f64..1.0),
            fov in 5.0f64..170.0,
            aspect in 0.2f64..5.0,
            near_exp in -3.0f64..1.0,
            far_ratio in 1.5f64..1e5,
            zo in any::<bool>(),
            ndc in prop::array::uniform3(-1.0f64..1.0),
            offset in prop::array::uniform3(-1.0f64..1.0),
            radius_exp in -4.0f64..3.0,
            on_surface in any::<bool>(),
        ) {
            let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
            prop_assume!(len > 1e-3);
            let depth = if zo { DepthRange::ZeroToOne } else { DepthRange::NegativeOneToOne };
            let near = 10f64.powf(near_exp);
            let far = near * far_ratio;
            let target = [eye[0] + dir[0], eye[1] + dir[1], eye[2] + dir[2]];
            let m = view_projection(eye, target, fov, aspect, near, far, depth);
            // A point inside: view depth between near and far, x and y within the cone.
            let dist = near + (far - near) * (ndc[2] * 0.5 + 0.5).powi(3);
            let g = (fov.to_radians() / 2.0).tan();
            let f = [dir[0] / len, dir[1] / len, dir[2] / len];
            let up = if f[1].abs() > 0.999 { [0.0, 0.0, 1.0] } else { [0.0, 1.0, 0.0] };
            let mut s = [f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0]];
            let sl = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
            s = s.map(|c| c / sl);
            let u = [s[1] * f[2] - s[2] * f[1], s[2] * f[0] - s[0] * f[2], s[0] * f[1] - s[1] * f[0]];
            let (x, y) = (ndc[0] * g * aspect * dist, ndc[1] * g * dist);
            let p: [f64; 3] = core::array::from_fn(|k| eye[k] + f[k] * dist + s[k] * x + u[k] * y);
            prop_assume!(clearly_inside(&m, p, depth));
            // The sphere: radius r, centre within r of p (on the surface, or inside).
            let r = 10f64.powf(radius_exp) * (1.0 + dist * 1e-3);
            let ol = (offset[0] * offset[0] + offset[1] * offset[1] + offset[2] * offset[2]).sqrt().max(1e-12);
            let k = if on_surface { r / ol } else { r.min(ol) / ol * 0.999 };
            let center = [0, 1, 2].map(|i| (p[i] + offset[i] * k) as f32);
            // The binary32 sphere must still contain p.
            let r32 = r as f32;
            let d2: f64 = (0..3).map(|i| (f64::from(center[i]) - p[i]).powi(2)).sum();
            prop_assume!(d2.sqrt() <= f64::from(r32));
            let frustum = Frustum::from_view_projection(&m, depth);
            prop_assert!(frustum.keeps(center, r32), "dropped a sphere holding {p:?}: {center:?} {r32}");
        }
    }

    /// Random patch spheres and visibility, written by the writer: all four modes return the
    /// same frustum-culled bits, the hierarchical shortcuts included.
    #[cfg(feature = "bake")]
    #[test]
    fn every_mode_culls_alike() {
        use crate::format::{BakeContents, encode};
        use crate::sampler::{SamplingParams, VisibilityMatrix};
        use crate::test_kit::rng::Rng;
        use crate::tiling::Patch;

        let mut rng = Rng::new(22);
        let params = SamplingParams {
            level: 2,
            resolution: 64,
            fov_deg: 40.0,
            center: [0.0; 3],
            radius: 1.0,
        };
        let count = 300u32;
        let patches: Vec<Patch> = (0..count)
            .map(|i| {
                // Spatially coherent runs of patches, as the bake's order tends to give.
                let a = i as f32 / count as f32 * core::f32::consts::TAU;
                Patch {
                    first: i,
                    count: 1,
                    area: 1.0,
                    center: [
                        0.8 * a.cos() + 0.1 * (rng.unit() as f32),
                        0.5 * (rng.unit() as f32) - 0.25,
                        0.8 * a.sin() + 0.1 * (rng.unit() as f32),
                    ],
                    radius: 0.02 + 0.1 * (rng.unit() as f32),
                    cone_axis: [0.0, 1.0, 0.0],
                    cone_cos: -1.0,
                }
            })
            .collect();
        let mut matrix = VisibilityMatrix::new(66, count);
        for v in 0..66 {
            for p in 0..count {
                if (rng.unit() as f32) < 0.5 {
                    matrix.set(v, p);
                }
            }
        }
        let bytes = encode(&BakeContents {
            sampling: &params,
            triangle_count: u64::from(count),
            patches: &patches,
            visibility: &matrix,
            shells: &[],
            reach: 0.0,
        });
        let pvis = Pvis::parse(&bytes).unwrap();
        let words = pvis.row_words();
        let mut scratch = vec![0u64; words];
        let mut stream_scratch = vec![0u64; pvis.scratch_bound()];
        let mut table = vec![0u64; pvis.expanded_bound()];
        let mut out = vec![0u64; words];
        let mut reference = vec![0u64; words];
        let mut streaming = pvis.streaming(&mut stream_scratch);
        let mut expanded = pvis.expand(&mut table);
        let (mut culled, mut kept_all, mut emptied) = (0u32, 0u32, 0u32);
        for i in 0..400 {
            let a = i as f64 * 0.37;
            let dist = 1.2 + 4.0 * rng.unit();
            let eye = [dist * a.cos(), 0.3 * (a * 1.3).sin(), dist * a.sin()];
            let jitter = 1.5 * (rng.unit() - 0.5);
            let target = [
                eye[0] * jitter * 0.3,
                rng.unit() - 0.5,
                eye[2] * jitter * 0.3,
            ];
            let fov = 10.0 + 80.0 * rng.unit();
            let depth = if i % 2 == 0 {
                DepthRange::ZeroToOne
            } else {
                DepthRange::NegativeOneToOne
            };
            let far = if i % 7 == 0 { 0.1 } else { 100.0 };
            let m = view_projection(eye, target, fov, 1.0, 0.01, far, depth);
            let frustum = Frustum::from_view_projection(&m, depth);
            let eye = eye.map(|c| c as f32);

            let plain = pvis.query(eye, &mut scratch);
            reference.copy_from_slice(plain.bits());
            let before: u32 = reference.iter().map(|w| w.count_ones()).sum();
            for p in plain.patches().collect::<Vec<_>>() {
                if !frustum.keeps_patch(&pvis.patch(p)) {
                    reference[p as usize / 64] &= !(1 << (p % 64));
                }
            }
            let after: u32 = reference.iter().map(|w| w.count_ones()).sum();
            culled += u32::from(after < before);
            kept_all += u32::from(after == before);
            emptied += u32::from(after == 0 && before > 0);

            assert_eq!(
                pvis.query_in_frustum(eye, &frustum, &mut scratch).bits(),
                &reference[..]
            );
            assert_eq!(
                streaming.query_in_frustum(eye, &frustum, &mut out).bits(),
                &reference[..]
            );
            let e = expanded.query_in_frustum(eye, &frustum);
            assert_eq!(e.bits(), &reference[..], "eye {i}");
            assert_eq!(e.count(), after);
        }
        assert!(
            culled > 100 && kept_all > 20 && emptied > 5,
            "{culled} {kept_all} {emptied}"
        );
    }
}
