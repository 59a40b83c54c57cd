//! Closed parametric surfaces for the engine model: superellipsoids (boxes, cylinders,
//! spheres and everything between; Barr 1981) and toothed tori (gears, rings).
//!
//! Both are emitted as quad grids split into triangles, counter-clockwise seen from outside.
//! A superellipsoid is a latitude–longitude grid closed by a vertex at each pole with triangle
//! fans; a torus grid wraps in both directions. Either way every edge is shared by exactly two
//! triangles, in opposite directions: the parts are closed, which is what makes the engine's
//! inside invisible. Cost: one `powf` pair (superellipsoid) or a `sin_cos` pair per vertex.

use std::f32::consts::{PI, TAU};
use std::io;

/// A closed surface in its own frame, centred at the origin.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Shape {
    /// `|x/rx|^(2/e2) + |y/ry|^(2/e2))^(e2/e1) + |z/rz|^(2/e1) = 1`, poles on `z`:
    /// `e → 0` boxy, `e = 1` ellipsoid. `nu` steps around `z`, `nv` from pole to pole.
    Superellipsoid {
        radii: [f32; 3],
        e_lat: f32,
        e_lon: f32,
        nu: u32,
        nv: u32,
    },
    /// A torus around `z` whose ring radius rises by `tooth_depth` on `teeth` flat-topped teeth.
    Gear {
        ring: f32,
        tube: f32,
        teeth: u32,
        tooth_depth: f32,
        nu: u32,
        nv: u32,
    },
}

/// A shape placed in the model: rotated by `axes` (columns: where the shape's x, y, z go, a
/// rotation), then moved to `centre`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Part {
    pub(crate) shape: Shape,
    pub(crate) axes: [[f32; 3]; 3],
    pub(crate) centre: [f32; 3],
}

/// `sign(x)·|x|^e`, the superellipsoid's signed power.
fn signed_pow(x: f32, e: f32) -> f32 {
    x.signum() * x.abs().powf(e)
}

impl Part {
    pub(crate) fn vertex_count(&self) -> u64 {
        match self.shape {
            Shape::Superellipsoid { nu, nv, .. } => 2 + u64::from(nu) * u64::from(nv - 1),
            Shape::Gear { nu, nv, .. } => u64::from(nu) * u64::from(nv),
        }
    }

    pub(crate) fn triangle_count(&self) -> u64 {
        match self.shape {
            Shape::Superellipsoid { nu, nv, .. } => 2 * u64::from(nu) * u64::from(nv - 1),
            Shape::Gear { nu, nv, .. } => 2 * u64::from(nu) * u64::from(nv),
        }
    }

    fn place(&self, p: [f32; 3]) -> [f32; 3] {
        let a = &self.axes;
        [0, 1, 2].map(|r| self.centre[r] + a[0][r] * p[0] + a[1][r] * p[1] + a[2][r] * p[2])
    }

    pub(crate) fn vertices(
        &self,
        emit: &mut dyn FnMut([f32; 3]) -> io::Result<()>,
    ) -> io::Result<()> {
        match self.shape {
            Shape::Superellipsoid {
                radii,
                e_lat,
                e_lon,
                nu,
                nv,
            } => {
                let at = |theta: f32, phi: f32| {
                    let (st, ct) = theta.sin_cos();
                    let (sp, cp) = phi.sin_cos();
                    let ring = signed_pow(st, e_lat);
                    self.place([
                        radii[0] * ring * signed_pow(cp, e_lon),
                        radii[1] * ring * signed_pow(sp, e_lon),
                        radii[2] * signed_pow(ct, e_lat),
                    ])
                };
                emit(self.place([0.0, 0.0, radii[2]]))?;
                for r in 1..nv {
                    let theta = PI * r as f32 / nv as f32;
                    for i in 0..nu {
                        emit(at(theta, TAU * i as f32 / nu as f32))?;
                    }
                }
                emit(self.place([0.0, 0.0, -radii[2]]))
            }
            Shape::Gear {
                ring,
                tube,
                teeth,
                tooth_depth,
                nu,
                nv,
            } => {
                for i in 0..nu {
                    let u = TAU * i as f32 / nu as f32;
                    // A clipped sine: flat-topped teeth with sloped flanks.
                    let tooth = (2.0 * (teeth as f32 * u).sin()).clamp(-1.0, 1.0);
                    let radius = ring + tooth_depth * 0.5 * (tooth + 1.0);
                    let (su, cu) = u.sin_cos();
                    for j in 0..nv {
                        let (sv, cv) = (TAU * j as f32 / nv as f32).sin_cos();
                        let reach = radius + tube * cv;
                        emit(self.place([reach * cu, reach * su, tube * sv]))?;
                    }
                }
                Ok(())
            }
        }
    }

    /// Emits the triangles with vertex indices offset by `base`.
    pub(crate) fn triangles(
        &self,
        base: u32,
        emit: &mut dyn FnMut([u32; 3]) -> io::Result<()>,
    ) -> io::Result<()> {
        match self.shape {
            Shape::Superellipsoid { nu, nv, .. } => {
                let north = base;
                let south = base + 1 + nu * (nv - 1);
                // Ring r (1..nv), column i (wrapping).
                let at = |r: u32, i: u32| base + 1 + (r - 1) * nu + i % nu;
                for i in 0..nu {
                    emit([north, at(1, i), at(1, i + 1)])?;
                }
                for r in 1..nv - 1 {
                    for i in 0..nu {
                        emit([at(r, i), at(r + 1, i), at(r + 1, i + 1)])?;
                        emit([at(r, i), at(r + 1, i + 1), at(r, i + 1)])?;
                    }
                }
                for i in 0..nu {
                    emit([at(nv - 1, i), south, at(nv - 1, i + 1)])?;
                }
                Ok(())
            }
            Shape::Gear { nu, nv, .. } => {
                let at = |i: u32, j: u32| base + (i % nu) * nv + j % nv;
                for i in 0..nu {
                    for j in 0..nv {
                        emit([at(i, j), at(i + 1, j), at(i + 1, j + 1)])?;
                        emit([at(i, j), at(i + 1, j + 1), at(i, j + 1)])?;
                    }
                }
                Ok(())
            }
        }
    }
}

/// Grid steps for a superellipsoid of about `triangles` triangles: `nu = 2·nv`, so
/// `2·nu·(nv − 1) ≈ 4·nv²`; at least 8 × 4 so it stays a closed solid.
pub(crate) fn superellipsoid_steps(triangles: f64) -> (u32, u32) {
    let nv = ((triangles / 4.0).sqrt().round() as u32).max(4);
    (2 * nv, nv)
}

/// Grid steps for a gear of about `triangles` triangles: `nu = 4·nv` (the ring is long, the
/// tube short), so `2·nu·nv = 8·nv²`; `nu` a multiple of 4 per tooth so teeth stay sharp.
pub(crate) fn gear_steps(triangles: f64, teeth: u32) -> (u32, u32) {
    let nv = ((triangles / 8.0).sqrt().round() as u32).max(3);
    let per_tooth = (4 * nv).div_ceil(teeth).max(4);
    (per_tooth * teeth, nv)
}
