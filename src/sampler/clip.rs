//! Sutherland–Hodgman clipping of a triangle in homogeneous clip space against the near plane
//! and the guard band (Sutherland & Hodgman 1974; Blinn & Newell 1978 for clipping before the
//! perspective division).
//!
//! Only triangles that reach behind the near plane or beyond the guard band come here; every
//! other triangle is rasterized directly. Each plane adds at most one vertex, so a triangle
//! becomes a convex polygon of at most 3 + 5 vertices.
//!
//! Watertightness: an edge is always cut by interpolating from its inside endpoint towards its
//! outside endpoint, so the two triangles sharing an edge compute bit-identical cut points and
//! no crack opens along the clipped part of the edge.
//! Cost: a few dozen flops per plane per vertex.

/// A clip-space half-space `a·cx + b·cy + c·w + d >= 0`.
pub(crate) type Plane = [f64; 4];

/// Planes a triangle is clipped against: near plane and the four guard-band planes.
pub(crate) const PLANE_COUNT: usize = 5;

/// Most vertices a clipped triangle can have.
pub(crate) const MAX_CLIPPED: usize = 3 + PLANE_COUNT;

/// A convex polygon in clip coordinates `[cx, cy, w]`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ClipPolygon {
    pub(crate) vertices: [[f64; 3]; MAX_CLIPPED],
    pub(crate) len: usize,
}

impl ClipPolygon {
    /// The polygon's vertices.
    pub(crate) fn vertices(&self) -> &[[f64; 3]] {
        &self.vertices[..self.len]
    }
}

/// The clip planes of a `resolution`² image with near plane `near` and a guard band reaching
/// `guard` pixels beyond each image edge.
pub(crate) fn planes(resolution: u32, near: f64, guard: f64) -> [Plane; PLANE_COUNT] {
    let far_edge = resolution as f64 + guard;
    [
        [0.0, 0.0, 1.0, -near],     // w >= near
        [1.0, 0.0, guard, 0.0],     // cx / w >= -guard
        [-1.0, 0.0, far_edge, 0.0], // cx / w <= resolution + guard
        [0.0, 1.0, guard, 0.0],     // cy / w >= -guard
        [0.0, -1.0, far_edge, 0.0], // cy / w <= resolution + guard
    ]
}

/// Clips triangle `tri` against every plane in `planes` (in order). The result may be empty.
pub(crate) fn clip_triangle(tri: [[f64; 3]; 3], planes: &[Plane; PLANE_COUNT]) -> ClipPolygon {
    let mut polygon = ClipPolygon {
        vertices: [[0.0; 3]; MAX_CLIPPED],
        len: 3,
    };
    polygon.vertices[..3].copy_from_slice(&tri);
    let mut scratch = polygon;
    for plane in planes {
        clip_against(&polygon, plane, &mut scratch);
        std::mem::swap(&mut polygon, &mut scratch);
        if polygon.len == 0 {
            break;
        }
    }
    polygon
}

/// Signed distance-like value of `v` from `plane`: `>= 0` inside.
#[inline]
pub(crate) fn distance(plane: &Plane, v: &[f64; 3]) -> f64 {
    plane[0] * v[0] + plane[1] * v[1] + plane[2] * v[2] + plane[3]
}

/// The point where segment `inside`–`outside` crosses the plane, always interpolated from the
/// inside end so that both triangles sharing the edge get the same bits.
fn cut(inside: &[f64; 3], d_in: f64, outside: &[f64; 3], d_out: f64) -> [f64; 3] {
    let t = d_in / (d_in - d_out);
    std::array::from_fn(|i| inside[i] + (outside[i] - inside[i]) * t)
}

fn clip_against(input: &ClipPolygon, plane: &Plane, output: &mut ClipPolygon) {
    output.len = 0;
    let vertices = input.vertices();
    let Some(last) = vertices.last() else {
        return;
    };
    let mut previous = *last;
    let mut d_previous = distance(plane, &previous);
    for &current in vertices {
        let d_current = distance(plane, &current);
        let (previous_in, current_in) = (d_previous >= 0.0, d_current >= 0.0);
        if previous_in != current_in {
            output.vertices[output.len] = if previous_in {
                cut(&previous, d_previous, &current, d_current)
            } else {
                cut(&current, d_current, &previous, d_previous)
            };
            output.len += 1;
        }
        if current_in {
            output.vertices[output.len] = current;
            output.len += 1;
        }
        previous = current;
        d_previous = d_current;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_triangle_is_unchanged() {
        let planes = planes(10, 0.1, 100.0);
        let tri = [[1.0, 1.0, 1.0], [5.0, 1.0, 1.0], [1.0, 5.0, 1.0]];
        assert_eq!(clip_triangle(tri, &planes).vertices(), &tri);
    }

    #[test]
    fn triangle_behind_the_near_plane_vanishes() {
        let planes = planes(10, 0.1, 100.0);
        let tri = [[1.0, 1.0, -1.0], [5.0, 1.0, -2.0], [1.0, 5.0, 0.05]];
        assert_eq!(clip_triangle(tri, &planes).len, 0);
    }

    #[test]
    fn near_plane_cut_makes_a_quad_on_the_plane() {
        let planes = planes(10, 0.5, 100.0);
        let tri = [[0.0, 0.0, -1.0], [4.0, 0.0, 1.0], [0.0, 4.0, 1.0]];
        let polygon = clip_triangle(tri, &planes);
        assert_eq!(polygon.len, 4);
        let on_plane = polygon
            .vertices()
            .iter()
            .filter(|v| (v[2] - 0.5).abs() < 1e-12);
        assert_eq!(on_plane.count(), 2);
        assert!(polygon.vertices().iter().all(|v| v[2] >= 0.5 - 1e-12));
    }

    #[test]
    fn shared_edge_is_cut_identically_in_both_directions() {
        let planes = planes(10, 0.3, 100.0);
        let (a, b) = ([0.1, 0.7, -1.3], [4.9, 0.2, 2.7]);
        let left = clip_triangle([a, b, [-3.0, 2.0, 2.0]], &planes);
        let right = clip_triangle([b, a, [3.0, -2.0, 2.0]], &planes);
        let expected = cut(&b, b[2] - 0.3, &a, a[2] - 0.3);
        assert!(left.vertices().contains(&expected), "{left:?}");
        assert!(right.vertices().contains(&expected), "{right:?}");
    }
}
