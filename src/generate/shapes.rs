//! Closed surfaces for the machine-like models: superellipsoids (boxes, cylinders, spheres and
//! everything between; Barr 1981), toothed tori (gears, rings), and the flat-sided solids of
//! exposed assemblies and lattices: gridded boxes, prisms (rods) and hollow tubes.
//!
//! All are emitted as quad grids split into triangles, counter-clockwise seen from outside.
//! A superellipsoid or a prism is a latitude–longitude grid closed by a vertex at each pole
//! with triangle fans; a torus or a tube grid wraps in both directions (a tube is a torus with
//! a rectangular profile); a box is six face grids whose border points are shared. Every edge
//! is shared by exactly two triangles, in opposite directions: the parts are closed, which is
//! what makes the engine's inside invisible. Cost: one `powf` pair (superellipsoid) or a
//! `sin_cos` pair per vertex.

use std::f32::consts::{PI, TAU};
use std::io;

use crate::sphere::{cross, dot};

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
    /// A box of half-extents `half` whose faces are grids of `steps[a]` cells along axis `a`
    /// (each at least 1); border points are shared between faces.
    Cuboid { half: [f32; 3], steps: [u32; 3] },
    /// A cylinder along `z` (a prism of `sides ≥ 3` sides) cut into `segments ≥ 1` bands
    /// along its length, closed by a fan at each end.
    Prism {
        radius: f32,
        half_length: f32,
        sides: u32,
        segments: u32,
    },
    /// A hollow cylinder along `z`, open along its axis (`inner < outer`): outer and inner
    /// walls of `segments ≥ 1` bands, joined by flat rings at the ends.
    Tube {
        outer: f32,
        inner: f32,
        half_length: f32,
        sides: u32,
        segments: u32,
    },
}

/// The identity rotation, for parts placed as they are.
pub(crate) const UNROTATED: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// A rotation (as [`Part::axes`]) taking the shape's `z` to the direction of `d` (which must
/// not be zero), turned by `angle` radians about it. Axis-aligned `d` give axis-aligned frames.
pub(crate) fn axes_along(d: [f32; 3], angle: f32) -> [[f32; 3]; 3] {
    let z = normalised(d);
    // Any direction far from z: its component across z is the frame's unturned x.
    let helper = if z[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let along = dot(helper, z);
    let x = normalised([0, 1, 2].map(|a| helper[a] - along * z[a]));
    let y = cross(z, x);
    let (s, c) = angle.sin_cos();
    let turned_x = [0, 1, 2].map(|a| c * x[a] + s * y[a]);
    let turned_y = [0, 1, 2].map(|a| c * y[a] - s * x[a]);
    [turned_x, turned_y, z]
}

fn normalised(a: [f32; 3]) -> [f32; 3] {
    let length = dot(a, a).sqrt();
    a.map(|c| c / length)
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
        match self.grid() {
            Grid::Sphere { nu, nv } => 2 + u64::from(nu) * u64::from(nv - 1),
            Grid::Torus { nu, nv } => u64::from(nu) * u64::from(nv),
            Grid::Box { steps } => {
                // The lattice points of the box less those strictly inside it.
                let [a, b, c] = steps.map(u64::from);
                (a + 1) * (b + 1) * (c + 1) - (a - 1) * (b - 1) * (c - 1)
            }
        }
    }

    pub(crate) fn triangle_count(&self) -> u64 {
        match self.grid() {
            Grid::Sphere { nu, nv } => 2 * u64::from(nu) * u64::from(nv - 1),
            Grid::Torus { nu, nv } => 2 * u64::from(nu) * u64::from(nv),
            Grid::Box { steps } => {
                let [a, b, c] = steps.map(u64::from);
                4 * (a * b + b * c + c * a)
            }
        }
    }

    /// The shape's connectivity: prisms share the superellipsoid's, tubes the torus's.
    fn grid(&self) -> Grid {
        match self.shape {
            Shape::Superellipsoid { nu, nv, .. } => Grid::Sphere { nu, nv },
            Shape::Prism {
                sides, segments, ..
            } => Grid::Sphere {
                nu: sides,
                nv: segments + 2,
            },
            Shape::Gear { nu, nv, .. } => Grid::Torus { nu, nv },
            Shape::Tube {
                sides, segments, ..
            } => Grid::Torus {
                nu: sides,
                nv: 2 * (segments + 1),
            },
            Shape::Cuboid { steps, .. } => Grid::Box { steps },
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
            Shape::Cuboid { half, steps } => {
                let [a, b, c] = steps;
                let at = |i: u32, j: u32, k: u32| {
                    let t = [
                        i as f32 / a as f32,
                        j as f32 / b as f32,
                        k as f32 / c as f32,
                    ];
                    self.place([0, 1, 2].map(|d| half[d] * (2.0 * t[d] - 1.0)))
                };
                // In index order (see `box_index`): the bottom layer, the rings, the top.
                for j in 0..=b {
                    for i in 0..=a {
                        emit(at(i, j, 0))?;
                    }
                }
                for k in 1..c {
                    for p in 0..2 * (a + b) {
                        let [i, j] = ring_point(a, b, p);
                        emit(at(i, j, k))?;
                    }
                }
                for j in 0..=b {
                    for i in 0..=a {
                        emit(at(i, j, c))?;
                    }
                }
                Ok(())
            }
            Shape::Prism {
                radius,
                half_length,
                sides,
                segments,
            } => {
                emit(self.place([0.0, 0.0, half_length]))?;
                for r in 0..=segments {
                    let z = half_length * (1.0 - 2.0 * r as f32 / segments as f32);
                    for i in 0..sides {
                        let (s, c) = (TAU * i as f32 / sides as f32).sin_cos();
                        emit(self.place([radius * c, radius * s, z]))?;
                    }
                }
                emit(self.place([0.0, 0.0, -half_length]))
            }
            Shape::Tube {
                outer,
                inner,
                half_length,
                sides,
                segments,
            } => {
                // The profile runs counter-clockwise in the (radius, z) plane, as the torus's
                // does: up the outer wall, then down the inner one.
                let height = |j: u32| half_length * (2.0 * j as f32 / segments as f32 - 1.0);
                for i in 0..sides {
                    let (s, c) = (TAU * i as f32 / sides as f32).sin_cos();
                    for j in 0..=segments {
                        emit(self.place([outer * c, outer * s, height(j)]))?;
                    }
                    for j in 0..=segments {
                        emit(self.place([inner * c, inner * s, height(segments - j)]))?;
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
        match self.grid() {
            Grid::Sphere { nu, nv } => {
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
            Grid::Torus { nu, nv } => {
                let at = |i: u32, j: u32| base + (i % nu) * nv + j % nv;
                for i in 0..nu {
                    for j in 0..nv {
                        emit([at(i, j), at(i + 1, j), at(i + 1, j + 1)])?;
                        emit([at(i, j), at(i + 1, j + 1), at(i, j + 1)])?;
                    }
                }
                Ok(())
            }
            Grid::Box { steps } => {
                // Each face as (fixed axis, its lattice value, u axis, v axis) with u × v
                // pointing out of the box, so the quads below turn counter-clockwise.
                let [a, b, c] = steps;
                let faces = [
                    (2, 0, 1, 0),
                    (2, c, 0, 1),
                    (1, 0, 0, 2),
                    (1, b, 2, 0),
                    (0, 0, 2, 1),
                    (0, a, 1, 2),
                ];
                for (fixed, value, u, v) in faces {
                    let at = |p: u32, q: u32| {
                        let mut point = [0; 3];
                        point[fixed] = value;
                        point[u] = p;
                        point[v] = q;
                        base.wrapping_add(box_index(steps, point))
                    };
                    for p in 0..steps[u] {
                        for q in 0..steps[v] {
                            emit([at(p, q), at(p + 1, q), at(p + 1, q + 1)])?;
                            emit([at(p, q), at(p + 1, q + 1), at(p, q + 1)])?;
                        }
                    }
                }
                Ok(())
            }
        }
    }
}

/// How a shape's vertices are connected.
enum Grid {
    /// A pole, `nv − 1` rings of `nu` vertices, a pole.
    Sphere { nu: u32, nv: u32 },
    /// `nu` profiles of `nv` vertices, wrapping both ways.
    Torus { nu: u32, nv: u32 },
    /// The surface points of a `steps[0] × steps[1] × steps[2]` cell lattice.
    Box { steps: [u32; 3] },
}

/// Index of the surface lattice point `[i, j, k]` of a box of `steps` cells: first the whole
/// bottom layer (`k = 0`, row by row), then one ring of `2·(a + b)` points per inner layer,
/// then the whole top layer. Computed in `u64`: a model past `u32` indices is refused before
/// it is written, so the truncation only matters to output that is never produced.
fn box_index([a, b, c]: [u32; 3], [i, j, k]: [u32; 3]) -> u32 {
    let [a, b, c, i, j, k] = [a, b, c, i, j, k].map(u64::from);
    let layer = (a + 1) * (b + 1);
    let ring = 2 * (a + b);
    let index = if k == 0 {
        j * (a + 1) + i
    } else if k == c {
        layer + (c - 1) * ring + j * (a + 1) + i
    } else {
        // Round the layer's border: along j = 0, up i = a, back along j = b, down i = 0.
        let p = if j == 0 {
            i
        } else if i == a {
            a + j
        } else if j == b {
            2 * a + b - i
        } else {
            2 * a + 2 * b - j
        };
        layer + (k - 1) * ring + p
    };
    index as u32
}

/// The `[i, j]` of position `p` on a box layer's border ring, the inverse of `box_index`'s.
fn ring_point(a: u32, b: u32, p: u32) -> [u32; 2] {
    if p <= a {
        [p, 0]
    } else if p <= a + b {
        [a, p - a]
    } else if p <= 2 * a + b {
        [2 * a + b - p, b]
    } else {
        [0, 2 * a + 2 * b - p]
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
