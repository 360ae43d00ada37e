//! The kept list's cells (`AnchorCells`): each body binned by its anchor in the grid of the
//! list's last rebuild, so that a body anchored afresh (`PairCache::reanchor`) is tested
//! against the bodies of its neighbouring cells, not against every body.

use super::Grid;
use crate::math::{Scalar, Vector};

/// No body (the end of a cell's chain) or no cell (a body tested against every body).
const NONE: u32 = u32::MAX;

/// The bodies binned by their anchors, each cell a doubly linked chain, so that a body moves
/// from cell to cell in O(1). A body whose bound is wider than the cells allow (`fit`) is
/// left out of the cells (`wide`): it is tested against every body, and every body anchored
/// afresh is tested against it.
#[derive(Clone, Debug, Default)]
pub struct AnchorCells {
    /// The rebuild's grid, if the list has one.
    grid: Option<Grid>,
    /// The widest bound a binned body may have [m]: two spheres no wider that overlap have
    /// centres in the same or neighbouring cells (the grid's own argument, `Grid::build`).
    fit: Scalar,
    /// Each cell's first body.
    head: Vec<u32>,
    /// Each body's next and previous body in its cell's chain.
    next: Vec<u32>,
    prev: Vec<u32>,
    /// Each body's cell, `NONE` for the wide ones.
    cell: Vec<u32>,
    /// The bodies not binned.
    wide: Vec<u32>,
}

impl AnchorCells {
    /// Bins each body as the rebuild's grid did (`cell_of`, `u32::MAX` for the bodies it left
    /// out as large).
    pub(super) fn build(&mut self, grid: Grid, cell_of: &[u32]) {
        let cells = grid.dims.iter().product::<usize>();
        self.fit = grid.fit();
        self.grid = Some(grid);
        self.head.clear();
        self.head.resize(cells, NONE);
        let n = cell_of.len();
        for v in [&mut self.next, &mut self.prev, &mut self.cell] {
            v.clear();
            v.resize(n, NONE);
        }
        self.wide.clear();
        for (k, &c) in cell_of.iter().enumerate() {
            match c {
                NONE => self.wide.push(k as u32),
                c => self.link(k, c),
            }
        }
    }

    /// Forgets the cells (the list is gone).
    pub(super) fn clear(&mut self) {
        self.grid = None;
    }

    /// Body k anchored afresh at `x` with bound `bound`: moved to the cell of `x`, or out of
    /// the cells if its bound is too wide for them (it stays out until the next rebuild).
    pub(super) fn rebin(&mut self, k: usize, x: Vector, bound: Scalar) {
        let Some(grid) = self.grid else { return };
        if self.cell[k] == NONE {
            return;
        }
        self.unlink(k);
        if bound <= self.fit {
            self.link(k, grid.index(grid.coords(x)) as u32);
        } else {
            self.wide.push(k as u32);
        }
    }

    /// Calls `visit(j)` for every body j whose anchored sphere may overlap that of body k,
    /// anchored at `x` (k itself included): the bodies of the 27 cells about `x` and every
    /// wide body. False, visiting none, when k is not binned (or there are no cells): then it
    /// must be tested against every body.
    pub(super) fn near(&self, k: usize, x: Vector, mut visit: impl FnMut(usize)) -> bool {
        let Some(grid) = self.grid.filter(|_| self.cell.get(k).is_some_and(|&c| c != NONE)) else {
            return false;
        };
        let [xs, ys, zs] = grid.around(x);
        for z in zs {
            for y in ys.clone() {
                for x in xs.clone() {
                    let mut j = self.head[grid.index([x, y, z])];
                    while j != NONE {
                        visit(j as usize);
                        j = self.next[j as usize];
                    }
                }
            }
        }
        self.wide.iter().for_each(|&j| visit(j as usize));
        true
    }

    fn link(&mut self, k: usize, c: u32) {
        let first = self.head[c as usize];
        (self.next[k], self.prev[k], self.cell[k]) = (first, NONE, c);
        if first != NONE {
            self.prev[first as usize] = k as u32;
        }
        self.head[c as usize] = k as u32;
    }

    fn unlink(&mut self, k: usize) {
        let (next, prev, c) = (self.next[k], self.prev[k], self.cell[k]);
        match prev {
            NONE => self.head[c as usize] = next,
            p => self.next[p as usize] = next,
        }
        if next != NONE {
            self.prev[next as usize] = prev;
        }
        self.cell[k] = NONE;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use crate::systems::cull::spheres_overlap;

    /// Every body whose sphere overlaps k's is visited exactly once by `near(k)`, through
    /// moves within the grid, past its edges and to bounds too wide for the cells.
    #[test]
    fn near_visits_every_overlapping_body_once() {
        for seed in 0..20 {
            let mut rng = SplitMix64::new(seed);
            let cell = rng.uniform(0.5, 2.0);
            let dims = [1 + (rng.next_u64() % 6) as usize, 1 + (rng.next_u64() % 6) as usize, 3];
            let grid = Grid { origin: Vector::new(-1.0, 2.0, 0.5), cell, dims, threshold: Scalar::INFINITY };
            let n = 80;
            let extent = Vector::new(dims[0] as Scalar, dims[1] as Scalar, dims[2] as Scalar) * cell;
            // Some anchors beyond the grid on every side: `coords` clamps them to its edge.
            let place = |rng: &mut SplitMix64| {
                let t = Vector::new(rng.uniform(-0.3, 1.3), rng.uniform(-0.3, 1.3), rng.uniform(-0.3, 1.3));
                grid.origin + t * extent
            };
            let mut anchor: Vec<Vector> = (0..n).map(|_| place(&mut rng)).collect();
            let mut bound: Vec<Scalar> = (0..n).map(|_| rng.uniform(0.0, 1.0) * grid.fit()).collect();
            // A tenth too wide for the cells from the start, as the grid leaves large bodies.
            let cell_of: Vec<u32> = (0..n)
                .map(|k| match rng.unit() < 0.1 {
                    true => NONE,
                    false => grid.index(grid.coords(anchor[k])) as u32,
                })
                .collect();
            let mut cells = AnchorCells::default();
            cells.build(grid, &cell_of);
            for round in 0..30 {
                let k = (rng.next_u64() % n as u64) as usize;
                anchor[k] = place(&mut rng);
                // Now and then wider than the cells allow: out of them from then on.
                let most = if rng.unit() < 0.1 { 3.0 } else { 1.0 };
                bound[k] = rng.uniform(0.0, most) * grid.fit();
                cells.rebin(k, anchor[k], bound[k]);
                for k in 0..n {
                    let mut seen = vec![0_u32; n];
                    if !cells.near(k, anchor[k], |j| seen[j] += 1) {
                        assert_eq!(cells.cell[k], NONE, "seed {seed} round {round}: a binned body is searched");
                        continue;
                    }
                    for j in 0..n {
                        assert!(seen[j] <= 1, "seed {seed} round {round}: {j} visited twice");
                        if spheres_overlap(anchor[k], bound[k], anchor[j], bound[j]) {
                            assert_eq!(seen[j], 1, "seed {seed} round {round}: {j} overlaps {k}, not visited");
                        }
                    }
                }
            }
        }
    }
}
