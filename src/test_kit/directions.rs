//! View directions for tests that must not wait for the sampling sphere: a Fibonacci lattice,
//! roughly uniform for any count.

/// `count` roughly uniform unit directions (Fibonacci lattice).
pub(crate) fn fibonacci_directions(count: u32) -> Vec<[f32; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f64;
            [(r * phi.cos()) as f32, y as f32, (r * phi.sin()) as f32]
        })
        .collect()
}
