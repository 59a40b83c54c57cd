//! Connected components, and the proximity links that let whole components fuse.
//!
//! A patch never spans two connected components unless the mesh has more components than
//! patches were asked for. In that case the greedy fusion ends with every component a single
//! patch; to go on, the remaining patches are sorted by the Morton code of their bounding-box
//! centres and each is linked to its next [`PROXIMITY_LINKS`] successors in that order. The
//! same greedy rule then runs over these links. Sorting along the Z-order curve is a cheap
//! stand-in for a nearest-neighbour graph; it is connected by construction.
//!
//! Cost: O(n α(n)) for counting components, O(c log c) for the links of c patches.

use super::aabb::Aabb;
use super::morton::morton_code;

/// How many Morton-order successors each component patch is linked to. Four lets a component
/// choose among a few spatially close candidates (the Z-order curve jumps at cell borders, so
/// the immediate successor is not always the closest) while keeping the graph sparse.
pub(crate) const PROXIMITY_LINKS: usize = 4;

/// The number of connected components of the graph given by `neighbours`.
pub(crate) fn count_components(neighbours: &[Vec<u32>]) -> u32 {
    let mut parent: Vec<u32> = (0..neighbours.len() as u32).collect();
    let mut components = neighbours.len() as u32;
    for (a, list) in neighbours.iter().enumerate() {
        for &b in list {
            let (ra, rb) = (find(&mut parent, a as u32), find(&mut parent, b));
            if ra != rb {
                parent[ra.max(rb) as usize] = ra.min(rb);
                components -= 1;
            }
        }
    }
    components
}

/// The representative of `x`, halving the path on the way.
pub(crate) fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

/// Proximity links between `patches` (ids with their boxes): each patch is linked both ways to
/// its next [`PROXIMITY_LINKS`] successors in Morton order over `bounds` (ties by id).
/// Returns `(patch, linked patches)` in Morton order.
pub(crate) fn proximity_links(patches: &[(u32, Aabb)], bounds: &Aabb) -> Vec<(u32, Vec<u32>)> {
    let mut sorted: Vec<(u64, u32)> = patches
        .iter()
        .map(|(id, b)| (morton_code(b.center(), bounds), *id))
        .collect();
    sorted.sort_unstable();
    let mut links: Vec<(u32, Vec<u32>)> = sorted.iter().map(|&(_, id)| (id, Vec::new())).collect();
    for i in 0..links.len() {
        for j in i + 1..links.len().min(i + 1 + PROXIMITY_LINKS) {
            let (a, b) = (links[i].0, links[j].0);
            links[i].1.push(b);
            links[j].1.push(a);
        }
    }
    links
}
