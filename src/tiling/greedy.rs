//! Greedy patch fusion (Meruvia 2002, §3.1): the smallest patch fuses with the neighbour that
//! keeps the union most compact and flattest.
//!
//! Every triangle starts as a patch. Repeatedly the patch of smallest area (ties: smaller
//! patch id) is fused with the neighbour whose union has the lowest cost (ties: smaller
//! neighbour id), until the target count remains or no patch has a neighbour left. A patch
//! without neighbours is a whole connected component and is set aside.
//!
//! The cost is the union's bounding-box diagonal times `1 + W · spread`, where the spread is
//! `1 − |Σ a·n| / Σ a` over the union's triangles (areas `a`, unit normals `n`): 0 for a flat
//! patch, 0.29 for two equal faces at a right angle. The seed paper fuses by the diagonal
//! alone; then patches wrap around the edges of boxes, plates and fins, and a patch whose
//! sides face several ways is seen from most directions. Keeping patches flat culls 9 points
//! more on the zoo's exposed engine, 2–3 on the airplane and 1 on the bunny (BENCHMARKS.md,
//! "Flat patches"); [`SPREAD_WEIGHT`] is `W`.
//!
//! Data structures, chosen so a run is O(n log n):
//! - a min-priority queue of `(area, id, version)` with lazy invalidation ([`super::queue`]):
//!   fusing bumps the survivor's version, so older entries of both patches are skipped;
//! - union–find over patch ids (a patch is named by one of its triangles), so neighbour lists
//!   may keep stale ids and resolve them on use;
//! - neighbour lists merged small-into-large, compacted (resolved, deduplicated) when a patch is
//!   popped and whenever a list has grown past twice its last compacted length.
//!
//! The loop is sequential and every choice has a total order (`f64::total_cmp`, then ids), so
//! the result is the same on every run and for every thread count.

use std::cmp::Ordering;

use rayon::prelude::*;

use super::aabb::Aabb;
use super::bounds::{cross_normal, length};
use super::queue::{FusionQueue, entry, id_and_version};

/// `W` of the fusion cost (module documentation): how much a patch's normal spread lengthens
/// its diagonal. The culling gain levels off from about 8 on the zoo's exposed engine.
pub(crate) const SPREAD_WEIGHT: f64 = 8.0;

/// What the fusion cost reads of a patch: a seed (a triangle, or a chunk's patch) or a union.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shape {
    /// Surface area.
    pub area: f64,
    /// Bounding box.
    pub bbox: Aabb,
    /// Sum of the area-weighted normals (half the triangles' cross products).
    pub normal: [f64; 3],
}

impl Shape {
    /// The shape of one triangle with corners `p` (its area as
    /// [`super::bounds::triangle_area`] gives it).
    pub fn of_triangle(p: [[f32; 3]; 3]) -> Shape {
        let cross = cross_normal(p);
        Shape {
            area: 0.5 * length(cross),
            bbox: Aabb::of_triangle(p),
            normal: cross.map(|c| 0.5 * c),
        }
    }
}

/// The cost of fusing `a` and `b` (module documentation), squared: the union's diagonal
/// squared times `(1 + W · spread)²`.
fn union_cost(a: &Shape, b: &Shape) -> f64 {
    let diagonal_squared = a.bbox.union(&b.bbox).diagonal_squared();
    let area = a.area + b.area;
    let spread = if area > 0.0 {
        (1.0 - length(add(a.normal, b.normal)) / area).max(0.0)
    } else {
        0.0
    };
    let stretch = 1.0 + SPREAD_WEIGHT * spread;
    diagonal_squared * stretch * stretch
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// A list is compacted once its length exceeds twice its last compacted length plus this
/// slack. The slack spares tiny lists from constant re-compaction; the doubling keeps the
/// amortised cost O(1) per appended entry.
const COMPACT_SLACK: usize = 16;

/// What the greedy reads of one patch, kept together so a visit costs two cache lines (as
/// separate arrays they cost five).
#[derive(Clone, Copy)]
struct Node {
    shape: Shape,
    /// Union–find parent; a patch is alive when it is its own parent.
    parent: u32,
    version: u32,
    /// Length of the neighbour list when it was last compacted.
    compacted_len: u32,
}

/// The state of a fusion: every patch, alive or already fused into another.
pub(crate) struct Fusion {
    nodes: Vec<Node>,
    neighbours: Vec<Vec<u32>>,
    alive: u32,
}

impl Fusion {
    /// One patch per seed (a triangle, or a patch of a chunk), with the seeds' shapes and
    /// neighbour lists. The seeds come as an iterator so that they are never held twice.
    pub fn new(
        seeds: impl IndexedParallelIterator<Item = Shape>,
        neighbours: Vec<Vec<u32>>,
    ) -> Fusion {
        let n = neighbours.len();
        debug_assert!(seeds.len() == n);
        let nodes = seeds
            .zip(neighbours.par_iter())
            .enumerate()
            .map(|(p, (shape, list))| Node {
                shape,
                parent: p as u32,
                version: 0,
                compacted_len: list.len() as u32,
            })
            .collect();
        Fusion {
            nodes,
            neighbours,
            alive: n as u32,
        }
    }

    /// Number of patches not yet fused into another.
    pub fn alive(&self) -> u32 {
        self.alive
    }

    /// The ids of the alive patches, ascending.
    pub fn alive_ids(&self) -> Vec<u32> {
        (0..self.nodes.len() as u32)
            .filter(|&p| self.nodes[p as usize].parent == p)
            .collect()
    }

    /// The bounding box of alive patch `p`.
    pub fn bbox(&self, p: u32) -> Aabb {
        self.nodes[p as usize].shape.bbox
    }

    /// The shape of alive patch `p`.
    pub fn shape(&self, p: u32) -> &Shape {
        &self.nodes[p as usize].shape
    }

    /// The neighbours of alive patch `p`: alive ids, ascending, without duplicates.
    pub fn neighbour_patches(&mut self, p: u32) -> &[u32] {
        self.compact(p);
        &self.neighbours[p as usize]
    }

    /// Replaces the neighbour list of alive patch `p`.
    pub fn set_neighbours(&mut self, p: u32, list: Vec<u32>) {
        self.nodes[p as usize].compacted_len = list.len() as u32;
        self.neighbours[p as usize] = list;
    }

    /// The alive patch that triangle (or patch id) `t` belongs to.
    pub fn patch_of(&mut self, t: u32) -> u32 {
        find(&mut self.nodes, t)
    }

    /// Fuses patches, starting from the alive patches `seeds`, until `target` patches remain
    /// or no seed-reachable patch has a neighbour. Returns the number of fusions.
    pub fn fuse(&mut self, seeds: &[u32], target: u32) -> u32 {
        let mut queue = FusionQueue::new(
            seeds
                .iter()
                .map(|&p| {
                    let node = &self.nodes[p as usize];
                    entry(node.shape.area, p, node.version)
                })
                .collect(),
        );
        let mut fusions = 0;
        while self.alive > target {
            let Some(e) = queue.pop() else { break };
            let (p, version) = id_and_version(e);
            let node = &self.nodes[p as usize];
            if node.parent != p || node.version != version {
                continue; // Stale: fused away, or re-queued with a newer area.
            }
            self.compact(p);
            let Some(q) = self.most_compact_neighbour(p) else {
                continue; // A whole connected component: set aside, never queued again.
            };
            let s = self.unite(p, q);
            let node = &self.nodes[s as usize];
            queue.push(entry(node.shape.area, s, node.version));
            fusions += 1;
        }
        fusions
    }

    /// The neighbour of `p` (list compacted) whose union with `p` costs least.
    fn most_compact_neighbour(&self, p: u32) -> Option<u32> {
        let np = &self.nodes[p as usize];
        let mut best: Option<(f64, u32)> = None;
        for &q in &self.neighbours[p as usize] {
            let d = union_cost(&np.shape, &self.nodes[q as usize].shape);
            let better = match best {
                None => true,
                Some((bd, bq)) => d.total_cmp(&bd).then(q.cmp(&bq)) == Ordering::Less,
            };
            if better {
                best = Some((d, q));
            }
        }
        best.map(|(_, q)| q)
    }

    /// Fuses alive patches `p` and `q`; the one with the longer neighbour list survives (ties:
    /// the smaller id) and absorbs the other's list. Returns the survivor.
    fn unite(&mut self, p: u32, q: u32) -> u32 {
        let (lp, lq) = (
            self.neighbours[p as usize].len(),
            self.neighbours[q as usize].len(),
        );
        let (s, l) = match lp.cmp(&lq) {
            Ordering::Greater => (p, q),
            Ordering::Less => (q, p),
            Ordering::Equal => (p.min(q), p.max(q)),
        };
        let (su, lu) = (s as usize, l as usize);
        let absorbed_node = self.nodes[lu];
        self.nodes[lu].parent = s;
        let survivor = &mut self.nodes[su];
        let (shape, absorbed) = (&mut survivor.shape, &absorbed_node.shape);
        shape.area += absorbed.area;
        shape.normal = add(shape.normal, absorbed.normal);
        shape.bbox = shape.bbox.union(&absorbed.bbox);
        survivor.version += 1;
        let compacted_len = survivor.compacted_len as usize;
        let absorbed = std::mem::take(&mut self.neighbours[lu]);
        self.neighbours[su].extend_from_slice(&absorbed);
        self.alive -= 1;
        if self.neighbours[su].len() > 2 * compacted_len + COMPACT_SLACK {
            self.compact(s);
        }
        s
    }

    /// Resolves the neighbour list of alive patch `p` to alive ids, without `p` itself and
    /// without duplicates.
    fn compact(&mut self, p: u32) {
        let list = &mut self.neighbours[p as usize];
        for q in list.iter_mut() {
            *q = find(&mut self.nodes, *q);
        }
        list.retain(|&q| q != p);
        list.sort_unstable();
        list.dedup();
        self.nodes[p as usize].compacted_len = list.len() as u32;
    }
}

/// The alive patch containing `x`, halving the path on the way.
fn find(nodes: &mut [Node], mut x: u32) -> u32 {
    while nodes[x as usize].parent != x {
        let up = nodes[nodes[x as usize].parent as usize].parent;
        nodes[x as usize].parent = up;
        x = up;
    }
    x
}
