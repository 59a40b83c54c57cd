//! The packed render target of tiled sampling: one `u64` per pixel holding the depth in the
//! high half and the fragment's patch, coded by [`low_half`], in the low half.
//!
//! Depth is `1/w` (larger is nearer) as `f32` bits; for positive floats the bit patterns sort
//! like the values, so one integer `max` is the whole depth test. On equal depth the larger
//! low half wins, i.e. the smaller patch id: exactly the fragment the reference renderer
//! ([`super::IdBuffer`]'s depth test) keeps. The buffer's content therefore does not depend
//! on the order triangles are drawn in, which is what lets the tiled sampler draw likely
//! occluders first and skip hidden patches while staying bit-identical to a brute-force
//! render. A cleared pixel is `0`, and a fragment with depth `<= 0` (never nearer than
//! "empty" in the reference) is dropped. The patch comes straight out of the key
//! ([`patch_slot`]), with no per-triangle table to look up.
//! Cost: 8 bytes per pixel, one load, `max` and store per fragment.
//!
//! The probe pass's shrunk occluders ([`DepthBuffer`], [`DepthBuffer::shrink_from`]) need
//! depths alone: the same buffer with `u32` pixels, half the bytes to write and to read, and
//! the same occlusion tests.
//!
//! A model at the sampling distance covers a fraction of its image: on average 12 % of the
//! pixels on the airplane, 30 % on the bunny. So each band of [`TILE`] rows keeps the span of
//! columns its patches may have written ([`Span`]; every pixel outside it is empty), and the
//! passes over whole images (draining, the tiles, the shrink) visit the spans alone. The
//! spans grow by each drawn patch's screen rectangle ([`KeyBuffer::mark`]): once per patch,
//! as widening them per triangle costs more than the passes save on dense meshes.

use super::camera::SphereBounds;
use super::conservative::scan_triangle_conservative;
use super::raster::{DEFAULT_PATHS, SUBPIXEL_BITS, ScreenVertex, scan_triangle_with_area};
use std::ops::Range;

/// Relative widening of a triangle's largest corner depth in [`KeyBuffer::triangle_hidden`]:
/// interpolated `f32` depths exceed it by a few ulps at most (~1e-7 relative), and
/// conservative fragments by 1e-9 relative; 1e-4 is a wide margin.
const TRIANGLE_DEPTH_SLACK: f32 = 1e-4;

/// Triangles whose pixel rectangle is narrower and lower than this many pixels are tested
/// against their pixels directly (a tile lookup costs more than a few pixels' depths).
const SMALL_RECT: usize = 4;

/// Pixels [`KeyBuffer::drain`] tests for emptiness at once: eight keys, four SSE2 registers
/// or-ed together.
const DRAIN_RUN: usize = 8;

/// Side of the square tiles of the occlusion map, in pixels.
pub(crate) const TILE: usize = 8;

/// What one pixel of a [`KeyBuffer`] holds: a packed key (`u64`, depth in the high half) or a
/// depth alone (`u32`). Either way 0 is empty.
pub(crate) trait Pixel: Copy + Default + Eq + std::fmt::Debug {
    /// The pixel's depth bits (0: empty).
    fn depth_bits(self) -> u32;
}

impl Pixel for u64 {
    #[inline(always)]
    fn depth_bits(self) -> u32 {
        (self >> 32) as u32
    }
}

impl Pixel for u32 {
    #[inline(always)]
    fn depth_bits(self) -> u32 {
        self
    }
}

/// The columns `[start, end)` of one band of [`TILE`] rows where a pixel may be written:
/// every pixel of the band outside them is empty. `start >= end`: the whole band is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Span {
    start: u32,
    end: u32,
}

impl Span {
    /// No column.
    const EMPTY: Span = Span {
        start: u32::MAX,
        end: 0,
    };

    fn is_empty(self) -> bool {
        self.start >= self.end
    }

    /// The columns, as a range to slice a row with (`0..0` when empty).
    fn range(self) -> Range<usize> {
        if self.is_empty() {
            0..0
        } else {
            self.start as usize..self.end as usize
        }
    }

    /// The smallest span holding both.
    fn union(self, other: Span) -> Span {
        Span {
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }

    /// The columns of both.
    fn intersect(self, other: Span) -> Span {
        Span {
            start: self.start.max(other.start),
            end: self.end.min(other.end),
        }
    }

    /// The columns of `self` outside `other`: up to two ranges, either possibly empty.
    fn minus(self, other: Span) -> [Range<usize>; 2] {
        if self.is_empty() {
            return [0..0, 0..0];
        }
        if other.is_empty() {
            return [self.range(), 0..0];
        }
        let (s, e) = (self.start as usize, self.end as usize);
        let (os, oe) = (other.start as usize, other.end as usize);
        [s..os.clamp(s, e), oe.clamp(s, e)..e]
    }

    /// The tiles of a band wholly inside the span, of `tiles_per_row` tiles over `n` columns
    /// (the last one partial when `n` is not a multiple of [`TILE`]): every other tile of the
    /// band holds an empty pixel.
    fn whole_tiles(self, n: usize, tiles_per_row: usize) -> Range<usize> {
        if self.is_empty() {
            return 0..0;
        }
        let first = (self.start as usize).div_ceil(TILE);
        let end = if self.end as usize >= n {
            tiles_per_row
        } else {
            self.end as usize / TILE
        };
        if first < end { first..end } else { 0..0 }
    }
}

/// The columns of the tiles `tiles` of a band `n` pixels wide.
fn tile_columns(tiles: &Range<usize>, n: usize) -> Range<usize> {
    tiles.start * TILE..(tiles.end * TILE).min(n)
}

/// The rows of band `band` of a `n`-row image.
fn band_rows(band: usize, n: usize) -> Range<usize> {
    band * TILE..((band + 1) * TILE).min(n)
}

/// Per-pixel packed keys of one view (or depths alone, [`DepthBuffer`]), plus the per-tile
/// farthest depth built from them.
#[derive(Debug)]
pub(crate) struct KeyBuffer<P: Pixel = u64> {
    resolution: usize,
    keys: Vec<P>,
    tiles_per_row: usize,
    /// Smallest depth bits (farthest) in each `TILE`² tile; 0 where a pixel is empty.
    tile_far: Vec<u32>,
    /// [`Self::build_tiles`]' per-column minima of one band of tiles.
    column_far: Vec<i32>,
    /// Per band of [`TILE`] rows, the columns that may hold a fragment (or a depth).
    spans: Vec<Span>,
}

/// The depths of a view without their patches: the probe pass's shrunk occluders.
pub(crate) type DepthBuffer = KeyBuffer<u32>;

impl<P: Pixel> KeyBuffer<P> {
    /// A cleared buffer of `resolution`² pixels.
    pub(crate) fn new(resolution: u32) -> KeyBuffer<P> {
        let resolution = resolution as usize;
        let tiles_per_row = resolution.div_ceil(TILE);
        KeyBuffer {
            resolution,
            keys: vec![P::default(); resolution * resolution],
            tiles_per_row,
            tile_far: vec![0; tiles_per_row * tiles_per_row],
            column_far: vec![0; resolution],
            spans: vec![Span::EMPTY; tiles_per_row],
        }
    }

    /// Widens the spans to every pixel that contents within `bounds` may write: a patch is
    /// marked before [`KeyBuffer::draw`] draws its triangles.
    #[inline(always)]
    pub(crate) fn mark(&mut self, bounds: SphereBounds) {
        match bounds {
            SphereBounds::Outside => {}
            SphereBounds::Rect { rect, .. } => self.mark_rect(rect),
            SphereBounds::Unbounded => {
                let last = self.resolution - 1;
                self.mark_rect([0, 0, last, last]);
            }
        }
    }

    /// Widens the spans to the inclusive pixel rectangle `[x0, y0, x1, y1]` (inside the image).
    #[inline(always)]
    fn mark_rect(&mut self, rect: [usize; 4]) {
        let [x0, y0, x1, y1] = rect;
        let span = Span {
            start: x0 as u32,
            end: x1 as u32 + 1,
        };
        for band in &mut self.spans[y0 / TILE..=y1 / TILE] {
            *band = band.union(span);
        }
    }

    /// Whether pixel `index` lies in its band's span: where [`KeyBuffer::drain`] and the
    /// tiles look for it.
    #[cfg(debug_assertions)]
    fn in_span(&self, index: usize) -> bool {
        let (x, y) = (index % self.resolution, index / self.resolution);
        self.spans[y / TILE].range().contains(&x)
    }
}

impl KeyBuffer {
    /// The packed keys, row by row from the top.
    pub(crate) fn keys(&self) -> &[u64] {
        &self.keys
    }

    /// Calls `f` with the key of every pixel that may hold a fragment, row by row from the
    /// top (the others are empty: key 0), and empties every pixel: the buffer is then as
    /// [`Self::new`] made it, ready for the next view without a clearing pass of its own.
    /// Only the bands' spans are visited; in them, runs of [`DRAIN_RUN`] empty pixels are
    /// skipped after one test, and only the others are written.
    #[inline(always)]
    pub(crate) fn drain(&mut self, mut f: impl FnMut(u64)) {
        let n = self.resolution;
        for (band, span) in self.spans.iter_mut().enumerate() {
            for y in band_rows(band, n) {
                for run in self.keys[y * n..][span.range()].chunks_mut(DRAIN_RUN) {
                    if run.iter().fold(0, |any, &k| any | k) == 0 {
                        continue;
                    }
                    for k in run {
                        f(*k);
                        *k = 0;
                    }
                }
            }
            *span = Span::EMPTY;
        }
    }

    /// Rasterizes screen triangle `tri` (signed area `area`) with key low half `low`
    /// ([`low_half`]): every pixel whose centre it covers, or with `conservative` every pixel
    /// square it touches ([`scan_triangle_conservative`]). The pixels it touches must be
    /// marked ([`Self::mark`]: its patch's bounds).
    #[inline(always)]
    pub(crate) fn draw(&mut self, tri: [ScreenVertex; 3], area: i64, low: u32, conservative: bool) {
        let resolution = self.resolution as u32;
        let plot = |index, q, covered| self.plot(index, q, low, covered);
        if conservative {
            scan_triangle_conservative(tri, resolution, plot);
        } else {
            scan_triangle_with_area(tri, area, resolution, DEFAULT_PATHS, plot);
        }
    }

    /// Depth test and write of a fragment with low half `low` ([`low_half`]) at depth `q`;
    /// branch-free like [`super::IdBuffer`]'s `plot`. The pixel lies in its band's span
    /// ([`Self::mark`]).
    #[inline(always)]
    fn plot(&mut self, index: usize, q: f32, low: u32, covered: bool) {
        let key = (u64::from(q.to_bits()) << 32) | u64::from(low);
        let key = if covered & (q > 0.0) { key } else { 0 };
        #[cfg(debug_assertions)]
        debug_assert!(
            key == 0 || self.in_span(index),
            "pixel {index} outside its span"
        );
        let stored = &mut self.keys[index];
        *stored = (*stored).max(key);
    }

    /// [`Self::plot`] with pixel `index` added to its band's span (tests write pixels one
    /// by one).
    #[cfg(test)]
    pub(crate) fn plot_marked(&mut self, index: usize, q: f32, low: u32, covered: bool) {
        let (x, y) = (index % self.resolution, index / self.resolution);
        self.mark_rect([x, y, x, y]);
        self.plot(index, q, low, covered);
    }
}

impl DepthBuffer {
    /// Makes this buffer the occluders of `source` shrunk by `radius` pixels: every pixel
    /// takes the farthest depth of `source` within the `(2 · radius + 1)`² square around it
    /// (an empty pixel there empties it), with its tiles. A fragment nearer than
    /// a pixel of the shrunk buffer may show from a camera that moves the occluders by up
    /// to `radius` pixels.
    ///
    /// Separable, in one pass over `source`: each source row's minimum over its window goes
    /// to a ring of `2 · radius + 1` rows in `ring` (a few KiB, which stay in cache), and each
    /// output row is the minimum of the ring rows of its window, written with the tiles'
    /// column minima. Every loop runs over whole rows of contiguous slices, which the
    /// compiler turns into SIMD.
    pub(crate) fn shrink_from(&mut self, source: &KeyBuffer, radius: usize, ring: &mut Vec<u32>) {
        #[cfg(target_arch = "x86_64")]
        if super::raster::has_avx2() {
            // SAFETY: the CPU has AVX2 (tested just above).
            unsafe { self.shrink_from_avx2(source, radius, ring) };
            return;
        }
        self.shrink(source, radius, ring);
    }

    /// [`Self::shrink_from`] compiled for AVX2 (found at run time: the build stays portable
    /// x86-64). The same integer operations, so the same depths: only eight lanes to an
    /// instruction, where baseline x86-64 (SSE2) has no 32-bit minimum and takes four
    /// instructions for four lanes' (the shrink was 18 % of the bunny's default bake).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn shrink_from_avx2(&mut self, source: &KeyBuffer, radius: usize, ring: &mut Vec<u32>) {
        self.shrink(source, radius, ring);
    }

    /// The body of [`Self::shrink_from`], inlined into each of its builds. Only the source's
    /// spans are visited: a pixel outside them is empty, so is its shrunk depth, and the
    /// buffer takes the source's spans (emptying first what the last shrink wrote outside
    /// them).
    #[inline(always)]
    fn shrink(&mut self, source: &KeyBuffer, radius: usize, ring: &mut Vec<u32>) {
        let n = self.resolution;
        debug_assert_eq!(n, source.resolution);
        let radius = radius.min(n.saturating_sub(1));
        let window = 2 * radius + 1;
        // One more row of scratch for the row minima's steps past the first.
        ring.resize((window + 1) * n, 0);
        let (ring, step) = ring.split_at_mut(window * n);
        let DepthBuffer {
            keys: depths,
            tiles_per_row,
            tile_far,
            column_far,
            spans,
            ..
        } = self;
        for (band, (old, &new)) in spans.iter_mut().zip(&source.spans).enumerate() {
            for y in band_rows(band, n) {
                for columns in old.minus(new) {
                    depths[y * n..][columns].fill(0);
                }
            }
            *old = new;
        }
        let span_of = |y: usize| source.spans[y / TILE];
        let columns = &mut column_far[..n];
        let mut ready = 0; // Source rows before it have their minima in the ring (if wanted).
        for (y, out) in depths.chunks_exact_mut(n).enumerate() {
            let own = span_of(y);
            let whole = own.whole_tiles(n, *tiles_per_row);
            let tiled = tile_columns(&whole, n);
            if y % TILE == 0 {
                columns[tiled.clone()].fill(i32::MAX);
            }
            if !own.is_empty() {
                let (a, b) = (y.saturating_sub(radius), (y + radius).min(n - 1));
                ready = ready.max(a);
                while ready <= b {
                    let span = span_of(ready);
                    if !span.is_empty() {
                        // Widened by the radius, so that the minima over the span itself
                        // are clamped only at the image's edges.
                        let (s, e) = (span.start as usize, span.end as usize);
                        let wide = s.saturating_sub(radius)..(e + radius).min(n);
                        let slot = &mut ring[ready % window * n..][..n];
                        row_window_min(
                            &source.keys[ready * n..][wide.clone()],
                            radius,
                            &mut slot[wide.clone()],
                            &mut step[wide],
                        );
                    }
                    ready += 1;
                }
                // The columns every row of the window may hold: the others are empty.
                let live = (a..=b).fold(own, |live, yy| live.intersect(span_of(yy)));
                for empty in own.minus(live) {
                    out[empty].fill(0);
                }
                let live = live.range();
                if !live.is_empty() {
                    let slot = |yy: usize| &ring[yy % window * n..][live.clone()];
                    let out = &mut out[live.clone()];
                    out.copy_from_slice(slot(a));
                    for yy in a + 1..=b {
                        for (o, &d) in out.iter_mut().zip(slot(yy)) {
                            *o = (*o).min(d);
                        }
                    }
                }
            }
            // Depth bits are those of a positive `f32` or 0 (empty), so they order as `i32`.
            for (far, &o) in columns[tiled.clone()].iter_mut().zip(&out[tiled.clone()]) {
                *far = (*far).min(o as i32);
            }
            if y % TILE == TILE - 1 || y == n - 1 {
                let tiles = &mut tile_far[y / TILE * *tiles_per_row..][..*tiles_per_row];
                tiles.fill(0);
                tiles_from_columns(&mut tiles[whole], &columns[tiled]);
            }
        }
    }

    /// Sets pixel `index` to depth `q` (tests of what reads the shrunk occluders).
    #[cfg(test)]
    pub(crate) fn set(&mut self, index: usize, q: f32) {
        let (x, y) = (index % self.resolution, index / self.resolution);
        self.mark_rect([x, y, x, y]);
        self.keys[index] = q.to_bits();
    }
}

/// The depths of one row of keys, each the minimum over the `2 · radius + 1` pixels around it
/// (clamped at the ends), into `out`; `step` is scratch of the row's length.
#[inline(always)]
fn row_window_min(keys: &[u64], radius: usize, out: &mut [u32], step: &mut [u32]) {
    // The first step straight from the keys (a copy of their depths at radius 0), then each
    // further step widens the window by one pixel on each side.
    min_of_three(keys, out, radius > 0);
    for _ in 1..radius {
        step.copy_from_slice(out);
        min_of_three(step, out, true);
    }
}

/// Each `out[x]` = the least depth of `source[x − 1..=x + 1]` (clamped at the ends), or of
/// `source[x]` alone without `widen`: one loop over the whole row, which the compiler turns
/// into SIMD.
#[inline(always)]
fn min_of_three<P: Pixel>(source: &[P], out: &mut [u32], widen: bool) {
    let n = source.len();
    let depth = |p: P| p.depth_bits();
    if !widen || n < 2 {
        for (o, &k) in out.iter_mut().zip(source) {
            *o = depth(k);
        }
        return;
    }
    out[0] = depth(source[0]).min(depth(source[1]));
    out[n - 1] = depth(source[n - 2]).min(depth(source[n - 1]));
    for (o, ((&l, &c), &r)) in out[1..n - 1]
        .iter_mut()
        .zip(source.iter().zip(&source[1..]).zip(&source[2..]))
    {
        *o = depth(l).min(depth(c)).min(depth(r));
    }
}

/// Each tile of one band of [`TILE`] rows takes the least of its columns' minima (as `i32`:
/// depth bits are those of a positive `f32` or 0, empty).
#[inline(always)]
fn tiles_from_columns(tiles: &mut [u32], columns: &[i32]) {
    for (t, c) in tiles.iter_mut().zip(columns.chunks(TILE)) {
        *t = c.iter().copied().min().unwrap_or(0) as u32;
    }
}

impl<P: Pixel> KeyBuffer<P> {
    /// The depth bits of pixel `index` (0: empty).
    #[inline(always)]
    pub(crate) fn depth_bits(&self, index: usize) -> u32 {
        self.keys[index].depth_bits()
    }

    /// Recomputes the farthest depth of every tile from the current keys: each band of
    /// [`TILE`] rows is folded into per-column minima first, a loop over whole rows that the
    /// compiler turns into SIMD (minima across eight keys of one tile took twelve instructions
    /// per pixel), and then each tile takes the minimum of its columns. Built for AVX2 where
    /// the CPU has it, as [`DepthBuffer::shrink_from`] is.
    pub(crate) fn build_tiles(&mut self) {
        #[cfg(target_arch = "x86_64")]
        if super::raster::has_avx2() {
            // SAFETY: the CPU has AVX2 (tested just above).
            unsafe { self.build_tiles_avx2() };
            return;
        }
        self.build_tiles_body();
    }

    /// [`Self::build_tiles`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn build_tiles_avx2(&mut self) {
        self.build_tiles_body();
    }

    /// The body of [`Self::build_tiles`], inlined into each of its builds. A tile not wholly
    /// inside its band's span holds an empty pixel: only the others are computed.
    #[inline(always)]
    fn build_tiles_body(&mut self) {
        let n = self.resolution;
        let columns = &mut self.column_far[..n];
        for ((band, tiles), span) in self
            .keys
            .chunks(n * TILE)
            .zip(self.tile_far.chunks_mut(self.tiles_per_row))
            .zip(&self.spans)
        {
            tiles.fill(0);
            let whole = span.whole_tiles(n, self.tiles_per_row);
            let tiled = tile_columns(&whole, n);
            let columns = &mut columns[tiled.clone()];
            // Depth bits are those of a positive `f32` or 0 (empty), so they order as `i32`,
            // which compiles to fewer instructions than an unsigned minimum.
            columns.fill(i32::MAX);
            for row in band.chunks_exact(n) {
                for (c, &k) in columns.iter_mut().zip(&row[tiled.clone()]) {
                    *c = (*c).min(k.depth_bits() as i32);
                }
            }
            tiles_from_columns(&mut tiles[whole], columns);
        }
    }

    /// Whether screen triangle `tri` provably changes no pixel: every pixel it may touch
    /// (centres inside its bounding box; with `conservative`, every pixel square the box
    /// meets) holds a depth strictly nearer than its largest corner depth widened by
    /// [`TRIANGLE_DEPTH_SLACK`], by the pixels themselves under [`SMALL_RECT`]² pixels and
    /// otherwise by the tiles of the last [`KeyBuffer::build_tiles`] ([`Self::occludes`]).
    /// A triangle touching no pixel is hidden too.
    #[inline(always)]
    pub(crate) fn triangle_hidden(&self, tri: [ScreenVertex; 3], conservative: bool) -> bool {
        let [a, b, c] = tri;
        self.extent_hidden(extent_of(tri), a.q.max(b.q).max(c.q), conservative)
    }

    /// The inclusive pixel rectangle `[x0, y0, x1, y1]` of the pixels a triangle within the
    /// snapped screen rectangle `extent` may write: whose centres `extent` holds, as in
    /// `scan_triangle` (centres `p · 256 + 128`), or with `conservative` a superset of the
    /// squares `scan_triangle_conservative` touches; clamped to the image, `None` if empty.
    #[inline(always)]
    fn pixel_rect(&self, extent: [i32; 4], conservative: bool) -> Option<[usize; 4]> {
        const SUBPIXEL: i64 = 1 << SUBPIXEL_BITS;
        let last = self.resolution as i64 - 1;
        let [min_x, max_x, min_y, max_y] = extent.map(i64::from);
        let (lo_bias, hi_bias) = if conservative {
            (-SUBPIXEL, 0)
        } else {
            (SUBPIXEL / 2 - 1, -SUBPIXEL / 2)
        };
        let x0 = ((min_x + lo_bias) >> SUBPIXEL_BITS).max(0);
        let x1 = ((max_x + hi_bias) >> SUBPIXEL_BITS).min(last);
        let y0 = ((min_y + lo_bias) >> SUBPIXEL_BITS).max(0);
        let y1 = ((max_y + hi_bias) >> SUBPIXEL_BITS).min(last);
        (x0 <= x1 && y0 <= y1).then_some([x0 as usize, y0 as usize, x1 as usize, y1 as usize])
    }

    /// Whether triangles with every corner within the snapped screen rectangle `[min_x,
    /// max_x, min_y, max_y]` and no corner depth above `q_max` provably change no pixel:
    /// [`Self::triangle_hidden`] for all of them at once.
    #[inline(always)]
    pub(crate) fn extent_hidden(&self, extent: [i32; 4], q_max: f32, conservative: bool) -> bool {
        let Some(rect) = self.pixel_rect(extent, conservative) else {
            return true;
        };
        let q = q_max * (1.0 + TRIANGLE_DEPTH_SLACK);
        if !(q.is_finite() && q > 0.0) {
            return false;
        }
        let [x0, y0, x1, y1] = rect;
        if x1 - x0 < SMALL_RECT && y1 - y0 < SMALL_RECT {
            // A few pixels (most triangles): their own depths decide, as the tiles would
            // with their fallback, and without the indirection.
            return self.pixels_all_nearer(rect, q.to_bits());
        }
        self.occludes(rect, q.to_bits())
    }

    /// Whether every pixel of the inclusive pixel rectangle `[x0, x1] × [y0, y1]` already
    /// holds a depth strictly nearer than `q_bits` (so that no fragment at depth `<= q` can
    /// change it): by the tiles of the last [`KeyBuffer::build_tiles`], and where a tile
    /// cannot tell (it holds an empty or a farther pixel somewhere), by the tile's pixels
    /// inside the rectangle. Exact per pixel, so a patch behind a silhouette is not drawn
    /// just because its rectangle meets a tile that reaches past it (at 6.4M triangles, 148
    /// instead of 192 tested patches drawn per view, of which 12.5 are visible on average).
    #[inline(always)]
    pub(crate) fn occludes(&self, rect: [usize; 4], q_bits: u32) -> bool {
        let [x0, y0, x1, y1] = rect;
        for ty in y0 / TILE..=y1 / TILE {
            let row = &self.tile_far[ty * self.tiles_per_row..][x0 / TILE..=x1 / TILE];
            for (i, &far) in row.iter().enumerate() {
                if far <= q_bits && !self.pixels_occlude(rect, x0 / TILE + i, ty, q_bits) {
                    return false;
                }
            }
        }
        true
    }

    /// Whether every pixel of the inclusive rectangle `rect` holds a depth strictly nearer
    /// than `q_bits`, pixel by pixel: [`Self::occludes`] without the tiles. Reads every
    /// pixel (no early exit, which would branch per pixel on these few); the tiles' fallback
    /// ([`Self::pixels_occlude`], up to 64 pixels) stops at the first farther one instead
    /// (sharing this loop there measured +1–3 % on the bunny and 6.4M).
    /// The rectangle is narrower than [`SMALL_RECT`] (4) pixels: each row is read as an array
    /// of its width, unrolled, with one bounds check per row instead of a loop over it.
    #[inline(always)]
    fn pixels_all_nearer(&self, rect: [usize; 4], q_bits: u32) -> bool {
        let [x0, y0, x1, y1] = rect;
        debug_assert!(x1 - x0 < SMALL_RECT);
        match x1 - x0 {
            0 => self.rows_all_nearer::<1>(x0, y0..=y1, q_bits),
            1 => self.rows_all_nearer::<2>(x0, y0..=y1, q_bits),
            2 => self.rows_all_nearer::<3>(x0, y0..=y1, q_bits),
            _ => self.rows_all_nearer::<4>(x0, y0..=y1, q_bits),
        }
    }

    /// [`Self::pixels_all_nearer`] for a rectangle `W` pixels wide from column `x0`.
    #[inline(always)]
    fn rows_all_nearer<const W: usize>(
        &self,
        x0: usize,
        rows: std::ops::RangeInclusive<usize>,
        q_bits: u32,
    ) -> bool {
        let mut nearer = true;
        for y in rows {
            let start = y * self.resolution + x0;
            // Inside the image by the caller's clamping; outside, nothing is proven.
            let Some(row) = self.keys.get(start..start + W) else {
                return false;
            };
            for &k in row {
                nearer &= k.depth_bits() > q_bits;
            }
        }
        nearer
    }

    /// [`Self::occludes`] for the pixels of tile `(tx, ty)` inside `rect`, where the tile's
    /// farthest depth cannot tell (it holds an empty or a farther pixel somewhere).
    #[inline(never)]
    fn pixels_occlude(&self, rect: [usize; 4], tx: usize, ty: usize, q_bits: u32) -> bool {
        let [x0, y0, x1, y1] = rect;
        let (px0, px1) = (x0.max(tx * TILE), x1.min(tx * TILE + TILE - 1));
        let (py0, py1) = (y0.max(ty * TILE), y1.min(ty * TILE + TILE - 1));
        (py0..=py1).all(|y| {
            let keys = &self.keys[y * self.resolution..][px0..=px1];
            keys.iter().all(|&k| k.depth_bits() > q_bits)
        })
    }
}

/// The snapped screen rectangle `[min_x, max_x, min_y, max_y]` of triangle `tri`'s corners.
#[inline(always)]
pub(crate) fn extent_of(tri: [ScreenVertex; 3]) -> [i32; 4] {
    let [a, b, c] = tri;
    [
        a.x.min(b.x).min(c.x),
        a.x.max(b.x).max(c.x),
        a.y.min(b.y).min(c.y),
        a.y.max(b.y).max(c.y),
    ]
}

/// The low half of patch `patch`'s keys among `patch_count` patches: `patch_count − patch`,
/// so that a smaller patch id wins a depth tie and no fragment's low half is 0.
#[inline(always)]
pub(crate) fn low_half(patch: u32, patch_count: u32) -> u32 {
    debug_assert!(patch < patch_count);
    patch_count - patch
}

/// The patch of a key among `patch_count` patches, or `patch_count` for an empty pixel
/// (a spare slot for branch-free counting).
#[inline(always)]
pub(crate) fn patch_slot(key: u64, patch_count: u32) -> usize {
    patch_count.wrapping_sub(key as u32) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `buffer`'s keys and tiles as if every pixel were in its band's span: the reference
    /// for what the spans let the passes skip.
    fn with_whole_spans<P: Pixel>(buffer: &KeyBuffer<P>) -> KeyBuffer<P> {
        let n = buffer.resolution;
        let mut whole = KeyBuffer::<P>::new(n as u32);
        whole.keys.copy_from_slice(&buffer.keys);
        whole.spans.fill(Span {
            start: 0,
            end: n as u32,
        });
        whole.build_tiles_body();
        whole
    }

    #[test]
    fn the_spans_change_nothing_view_after_view() {
        // Views of a few triangles each, in buffers reused as the sampler reuses them: the
        // shrink, both kinds of tiles and the drain give what they give over whole images,
        // and a drained buffer is empty (also outside this view's spans, where the last
        // view's pixels were).
        let mut rng = crate::test_kit::rng::Rng::new(17);
        let mut below = |m: u64| (rng.next_u64() % m) as i32;
        let mut fragments = 0;
        for n in [1usize, 8, 23, 64] {
            let mut keys = KeyBuffer::new(n as u32);
            let mut shrunk = DepthBuffer::new(n as u32);
            let mut ring = Vec::new();
            for view in 0..40 {
                let size = n as i32 * 256;
                for _ in 0..below(12) {
                    // Triangles up to a third of the image, partly outside it now and then.
                    let (x, y) = (
                        below(size as u64 + 512) - 256,
                        below(size as u64 + 512) - 256,
                    );
                    let reach = (size / 3).max(300) as u64;
                    let mut corner = || ScreenVertex {
                        x: x + below(reach),
                        y: y + below(reach),
                        q: 0.1 + below(50) as f32 * 0.01,
                    };
                    let tri = [corner(), corner(), corner()];
                    let area = crate::sampler::raster::signed_area(tri);
                    // What a patch of this one triangle is marked with.
                    if let Some(rect) = keys.pixel_rect(extent_of(tri), true) {
                        keys.mark_rect(rect);
                    }
                    keys.draw(tri, area, 1 + below(9) as u32, view % 2 == 0);
                }
                let radius = below(4) as usize;
                shrunk.shrink_from(&keys, radius, &mut ring);
                let whole = with_whole_spans(&keys);
                for y in 0..n {
                    for x in 0..n {
                        let window = |c: usize| c.saturating_sub(radius)..=(c + radius).min(n - 1);
                        let far = window(y)
                            .flat_map(|yy| window(x).map(move |xx| (xx, yy)))
                            .map(|(xx, yy)| keys.depth_bits(yy * n + xx))
                            .min()
                            .unwrap();
                        assert_eq!(
                            shrunk.depth_bits(y * n + x),
                            far,
                            "{n}² view {view} at {x}, {y}"
                        );
                    }
                }
                assert_eq!(
                    shrunk.tile_far,
                    with_whole_spans(&shrunk).tile_far,
                    "{n}² view {view}"
                );
                keys.build_tiles();
                assert_eq!(keys.tile_far, whole.tile_far, "{n}² view {view}");
                let mut drained: Vec<u64> = Vec::new();
                keys.drain(|k| {
                    if k != 0 {
                        drained.push(k)
                    }
                });
                let mut expected: Vec<u64> =
                    whole.keys.iter().copied().filter(|&k| k != 0).collect();
                drained.sort_unstable();
                expected.sort_unstable();
                fragments += drained.len();
                assert_eq!(drained, expected, "{n}² view {view}");
                assert!(keys.keys.iter().all(|&k| k == 0), "{n}² view {view}");
            }
        }
        assert!(fragments > 5_000, "{fragments} fragments drawn");
    }

    #[test]
    fn shrinking_takes_the_farthest_depth_of_each_square() {
        let n = 23;
        let mut rng = crate::test_kit::rng::Rng::new(5);
        let mut source = KeyBuffer::new(n as u32);
        for i in 0..n * n {
            // A few empty pixels among depths of few distinct values.
            if !rng.next_u64().is_multiple_of(9) {
                let q = 0.1 + (rng.next_u64() % 50) as f32 * 0.01;
                source.plot_marked(i, q, 1, true);
            }
        }
        let mut shrunk = DepthBuffer::new(n as u32);
        let mut ring = Vec::new();
        for radius in [0, 1, 2, 3, 5, 22, 40] {
            shrunk.shrink_from(&source, radius, &mut ring);
            for y in 0..n {
                for x in 0..n {
                    let window = |c: usize| c.saturating_sub(radius)..=(c + radius).min(n - 1);
                    let source = &source;
                    let far = window(y)
                        .flat_map(|yy| window(x).map(move |xx| source.depth_bits(yy * n + xx)))
                        .min()
                        .unwrap();
                    assert_eq!(
                        shrunk.depth_bits(y * n + x),
                        far,
                        "radius {radius} at {x}, {y}"
                    );
                }
            }
            // The tiles `build_tiles` makes of the shrunk depths (23 pixels: the last band
            // and column of tiles are partial).
            let mut rebuilt = DepthBuffer::new(n as u32);
            rebuilt.keys.copy_from_slice(&shrunk.keys);
            rebuilt.spans.copy_from_slice(&shrunk.spans);
            rebuilt.build_tiles();
            assert_eq!(rebuilt.tile_far, shrunk.tile_far, "radius {radius}");
            let mut body = DepthBuffer::new(n as u32);
            body.keys.copy_from_slice(&shrunk.keys);
            body.spans.copy_from_slice(&shrunk.spans);
            body.build_tiles_body();
            assert_eq!(body.tile_far, shrunk.tile_far, "radius {radius}");
            // The portable build of the shrink, where `shrink_from` took the AVX2 one.
            let mut portable = DepthBuffer::new(n as u32);
            portable.shrink(&source, radius, &mut ring);
            assert_eq!(portable.keys, shrunk.keys, "radius {radius}");
            assert_eq!(portable.tile_far, shrunk.tile_far, "radius {radius}");
        }
        // The packed keys' tiles, both builds (AVX2 where the CPU has it, and portable).
        let mut keys = KeyBuffer::new(n as u32);
        keys.keys.copy_from_slice(&source.keys);
        keys.spans.copy_from_slice(&source.spans);
        keys.build_tiles();
        source.build_tiles_body();
        assert_eq!(keys.tile_far, source.tile_far);
        // A buffer of one pixel, and of one row's width.
        for n in [1u32, 2] {
            let mut one = KeyBuffer::new(n);
            one.plot_marked(0, 0.5, 1, true);
            let mut shrunk = DepthBuffer::new(n);
            shrunk.shrink_from(&one, 1, &mut ring);
            let expect = if n == 1 { 0.5f32.to_bits() } else { 0 };
            assert_eq!(shrunk.depth_bits(0), expect, "{n} pixels");
        }
    }

    #[test]
    fn nearer_wins_and_equal_depth_keeps_the_smaller_patch() {
        const PATCHES: u32 = 10;
        let low = |p| low_half(p, PATCHES);
        let patch = |b: &KeyBuffer, i: usize| patch_slot(b.keys()[i], PATCHES);
        let mut b = KeyBuffer::new(2);
        assert_eq!(patch(&b, 0), PATCHES as usize);
        b.plot_marked(0, 0.5, low(7), true);
        b.plot_marked(0, 0.5, low(9), true);
        assert_eq!(patch(&b, 0), 7);
        b.plot_marked(0, 0.5, low(3), true);
        assert_eq!(patch(&b, 0), 3);
        b.plot_marked(0, 0.5, low(0), true);
        assert_eq!(patch(&b, 0), 0);
        b.plot_marked(0, 0.25, low(1), true);
        assert_eq!(patch(&b, 0), 0);
        b.plot_marked(0, 0.75, low(8), false);
        b.plot_marked(1, 0.0, low(8), true);
        b.plot_marked(1, -1.0, low(8), true);
        b.plot_marked(1, f32::NAN, low(8), true);
        assert_eq!(patch(&b, 0), 0);
        assert_eq!(b.keys()[1], 0);
    }

    #[test]
    fn drain_reports_every_fragment_and_leaves_the_buffer_empty() {
        const PATCHES: u32 = 5;
        // 13² pixels: the last run of eight is partial.
        let mut b = KeyBuffer::new(13);
        let pixels = [0, 7, 8, 100, 168];
        for (k, &i) in pixels.iter().enumerate() {
            b.plot_marked(i, 0.5, low_half(k as u32, PATCHES), true);
        }
        let mut seen = Vec::new();
        b.drain(|key| {
            if key != 0 {
                seen.push(patch_slot(key, PATCHES));
            }
        });
        assert_eq!(seen, [0, 1, 2, 3, 4]);
        assert!(b.keys().iter().all(|&k| k == 0));
        let mut calls = 0;
        b.drain(|_| calls += 1);
        assert_eq!(calls, 0, "an empty buffer has no run to report");
    }

    #[test]
    fn tiles_hold_the_farthest_depth_and_empty_pixels_never_occlude() {
        let mut b = KeyBuffer::new(16);
        for i in 0..256 {
            b.plot_marked(i, 0.5, !0, i != 200);
        }
        b.build_tiles();
        let half = 0.5f32.to_bits();
        // Tile (0, 0) is full at 0.5: hides anything strictly farther, not equal depth.
        assert!(b.occludes([0, 0, 7, 7], half - 1));
        assert!(!b.occludes([0, 0, 7, 7], half));
        // Pixel 200 = (8, 12) is empty: tile (1, 1) cannot decide, its pixels do.
        assert!(!b.occludes([8, 12, 8, 12], 1));
        assert!(!b.occludes([7, 11, 9, 13], 1));
        assert!(!b.occludes([0, 0, 15, 15], half - 1));
        assert!(b.occludes([9, 9, 15, 15], half - 1));
        assert!(b.occludes([8, 8, 15, 11], half - 1));
        assert!(!b.occludes([9, 9, 15, 15], half));
    }

    #[test]
    fn an_extent_hidden_hides_every_triangle_inside_it() {
        // What lets a cluster of triangles be passed over by the extent of its vertices: a
        // hidden extent hides every triangle whose corners lie in it, at no greater depth,
        // in both rasterization modes (small rectangles by their pixels, large ones by the
        // tiles), and a visible triangle's extent is never hidden.
        let n = 40;
        let mut rng = crate::test_kit::rng::Rng::new(11);
        let mut below = |m: u64| (rng.next_u64() % m) as i64;
        let mut b = KeyBuffer::new(n as u32);
        for i in 0..n * n {
            // Mostly near depths, a few far ones and empty pixels: holes to be seen through.
            match below(40) {
                0 => {}
                1 | 2 => b.plot_marked(i, 0.1, 1, true),
                _ => b.plot_marked(i, 0.6 + below(10) as f32 * 0.01, 1, true),
            }
        }
        b.build_tiles();
        let (mut hidden, mut shown) = (0, 0);
        for _ in 0..4000 {
            // A cluster of a few triangles within a box of up to 12 pixels, partly outside
            // the image now and then.
            let size = 64 + below(12 * 256);
            let (x0, y0) = (
                below(n as u64 * 256 + 512) - 256,
                below(n as u64 * 256 + 512) - 256,
            );
            let count = 1 + below(6);
            let mut corner = || ScreenVertex {
                x: (x0 + below(size as u64)) as i32,
                y: (y0 + below(size as u64)) as i32,
                q: 0.2 + below(40) as f32 * 0.01,
            };
            let triangles: Vec<[ScreenVertex; 3]> =
                (0..count).map(|_| [corner(), corner(), corner()]).collect();
            let all = triangles.iter().flatten();
            let extent = [
                all.clone().map(|v| v.x).min().unwrap(),
                all.clone().map(|v| v.x).max().unwrap(),
                all.clone().map(|v| v.y).min().unwrap(),
                all.clone().map(|v| v.y).max().unwrap(),
            ];
            let q_max = all.map(|v| v.q).fold(f32::NEG_INFINITY, f32::max);
            for conservative in [false, true] {
                let each = triangles
                    .iter()
                    .all(|&t| b.triangle_hidden(t, conservative));
                if b.extent_hidden(extent, q_max, conservative) {
                    assert!(each, "{extent:?} at {q_max}, conservative {conservative}");
                    hidden += 1;
                } else {
                    shown += 1;
                }
            }
        }
        assert!(
            hidden > 500 && shown > 500,
            "{hidden} hidden, {shown} shown"
        );
    }

    #[test]
    fn triangles_are_hidden_only_behind_full_tiles_of_nearer_depth() {
        let mut b = KeyBuffer::new(16);
        for y in 0..8 {
            for x in 0..8 {
                b.plot_marked(y * 16 + x, 0.5, !0, true);
            }
        }
        b.build_tiles();
        // Pixel (x, y) has its centre at sub-pixel (256 x + 128, 256 y + 128).
        let tri = |x: [i32; 3], y: [i32; 3], q: f32| {
            [0, 1, 2].map(|i| ScreenVertex {
                x: x[i],
                y: y[i],
                q,
            })
        };
        let inside = ([300, 1500, 300], [300, 300, 1500]);
        for conservative in [false, true] {
            assert!(b.triangle_hidden(tri(inside.0, inside.1, 0.4), conservative));
            // Equal depth may still win on the triangle index.
            assert!(!b.triangle_hidden(tri(inside.0, inside.1, 0.5), conservative));
            // Reaching into the empty tile (1, 0).
            let wide = tri([300, 2200, 300], [300, 300, 1500], 0.4);
            assert!(!b.triangle_hidden(wide, conservative));
        }
        // Between the centres of pixels 8 and 9 in x, inside empty tile (1, 0): covers no
        // centre, but its pixel squares are touched.
        let sliver = tri([2200, 2250, 2200], [300, 300, 350], 0.4);
        assert!(b.triangle_hidden(sliver, false));
        assert!(!b.triangle_hidden(sliver, true));
    }
}
