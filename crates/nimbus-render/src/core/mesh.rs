//! Index buffers of regular grids (the terrain and the stratus layer).

/// Triangle indices of a row-major n × n vertex grid: two triangles per
/// cell, counter-clockwise seen from +Y (+Z is south, so (a, c, b) turns
/// anticlockwise from above).
pub fn grid_indices(n: u32) -> Vec<u32> {
    let cells = n.saturating_sub(1);
    let mut indices = Vec::with_capacity((cells * cells * 6) as usize);
    for j in 0..cells {
        for i in 0..cells {
            let a = j * n + i;
            let (b, c) = (a + 1, a + n);
            indices.extend_from_slice(&[a, c, b, b, c, c + 1]);
        }
    }
    indices
}
