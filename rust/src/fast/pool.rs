//! Spread grids kept for reuse between calls (zeroing a kept grid costs less than a fresh
//! allocation's page faults).

/// Spread grids kept for reuse between calls, and their total size in bytes. A fresh grid
/// per task (about 200 KB at the default record) costs page faults and the kernel's zeroing;
/// zeroing a reused grid in place is cheaper.
static GRID_POOL: std::sync::Mutex<(Vec<Vec<f64>>, usize)> = std::sync::Mutex::new((Vec::new(), 0));
/// The most bytes of grids kept in [`GRID_POOL`].
const GRID_POOL_BYTES: usize = 64 << 20;

/// A zeroed spread grid of `len` values (reused when one is kept).
pub(crate) fn take_grid(len: usize) -> Vec<f64> {
    let reused = {
        // (the latest kept grid that is long enough: the pool holds grids of several sizes,
        // band and sub-band, and growing a short one reallocates, copies and page-faults)
        let mut pool = GRID_POOL.lock().unwrap_or_else(|e| e.into_inner());
        let at = pool.0.iter().rposition(|g| g.capacity() >= len);
        let g = at.map(|i| pool.0.swap_remove(i));
        if let Some(g) = &g {
            pool.1 -= g.capacity() * 8;
        }
        g
    };
    match reused {
        Some(mut g) => {
            g.clear();
            g.resize(len, 0.0);
            g
        }
        None => vec![0.0; len],
    }
}

/// Keep a grid for [`take_grid`] (dropped when the pool is full).
pub(crate) fn give_grid(g: Vec<f64>) {
    let bytes = g.capacity() * 8;
    let mut pool = GRID_POOL.lock().unwrap_or_else(|e| e.into_inner());
    if pool.1 + bytes <= GRID_POOL_BYTES {
        pool.1 += bytes;
        pool.0.push(g);
    }
}
