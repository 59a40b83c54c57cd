//! Greedy patch fusion (Meruvia 2002, §3.1): the smallest patch fuses with the neighbour that
//! keeps the union most compact.
//!
//! Every triangle starts as a patch. Repeatedly the patch of smallest area (ties: smaller
//! patch id) is fused with the neighbour whose union has the shortest bounding-box diagonal
//! (ties: smaller neighbour id), until the target count remains or no patch has a neighbour
//! left. A patch without neighbours is a whole connected component and is set aside.
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

use super::aabb::Aabb;
use super::queue::{FusionQueue, entry, id_and_version};

/// A list is compacted once its length exceeds twice its last compacted length plus this
/// slack. The slack spares tiny lists from constant re-compaction; the doubling keeps the
/// amortised cost O(1) per appended entry.
const COMPACT_SLACK: usize = 16;

/// What the greedy reads of one patch, kept together so a visit costs one cache line (as
/// separate arrays they cost four).
#[derive(Clone, Copy)]
struct Node {
    bbox: Aabb,
    area: f64,
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
    /// One patch per triangle, with the triangles' areas, boxes and neighbour lists.
    pub fn new(area: Vec<f64>, bbox: Vec<Aabb>, neighbours: Vec<Vec<u32>>) -> Fusion {
        let n = area.len();
        debug_assert!(bbox.len() == n && neighbours.len() == n);
        let nodes = (0..n)
            .map(|p| Node {
                bbox: bbox[p],
                area: area[p],
                parent: p as u32,
                version: 0,
                compacted_len: neighbours[p].len() as u32,
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
        self.nodes[p as usize].bbox
    }

    /// The area of alive patch `p`.
    pub fn area(&self, p: u32) -> f64 {
        self.nodes[p as usize].area
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
                    entry(node.area, p, node.version)
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
            queue.push(entry(node.area, s, node.version));
            fusions += 1;
        }
        fusions
    }

    /// The neighbour of `p` (list compacted) whose union with `p` has the smallest diagonal.
    fn most_compact_neighbour(&self, p: u32) -> Option<u32> {
        let bp = self.nodes[p as usize].bbox;
        let mut best: Option<(f64, u32)> = None;
        for &q in &self.neighbours[p as usize] {
            let d = bp.union(&self.nodes[q as usize].bbox).diagonal_squared();
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
        survivor.area += absorbed_node.area;
        survivor.bbox = survivor.bbox.union(&absorbed_node.bbox);
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
