//! The joints' equality rows (a ball joint's point, a hinge's point and tilt, a slider's offset
//! and turn, a weld, a rod) solved together and exactly, as one sparse linear system
//! K λ = r with K = J M⁻¹ Jᵀ, by a block LDLᵀ factorisation over the joints' graph: two joints
//! are neighbours when they share a free body (docs/joints.md, "How they are solved").
//!
//! Gauss–Seidel, one joint after another, carries a load along a chain one link per sweep and
//! converges the slower the heavier the load: a chain of 30 light links holding a heavy ball
//! needs tens of sweeps. Factorised, the whole chain takes its load in every pass, whatever the
//! mass ratio (Baraff, "Linear-time dynamics using Lagrange multipliers", 1996). Joints are
//! eliminated fewest neighbours first, so a chain, a tree of limbs or any number of separate
//! pendulums factor without fill; a loop (a body jointed twice into one ring) only fills the
//! blocks around it.
//!
//! The system is factorised once each time the bodies move (once a substep) and solved in every
//! pass; inequality rows (limits, motors, cones, springs) stay one-by-one (`joint_pass`).

use super::BodyStore;
use super::joint_pass::End;
use crate::math::{Scalar, Vector};
use std::cmp::Reverse;
use std::collections::{BTreeSet, BinaryHeap, HashMap};

/// Most equality rows of one joint (a weld's six).
pub(crate) const MAX_ROWS: usize = 6;

/// A dense block of at most `MAX_ROWS` × `MAX_ROWS`, row-major with that stride.
pub(super) type Block = [Scalar; MAX_ROWS * MAX_ROWS];

/// A pivot below this fraction of its row's own K_ii is a row the others already fix (or a
/// degenerate one): it is dropped, so a redundant joint neither fails nor pushes twice.
pub(super) const DROP: Scalar = 1e-12;

/// One equality row in the solver's scaled coordinates: the speed it measures is
/// lin·(v_a − v_b) + g_a·ŵ_a − g_b·ŵ_b, with g = S (r × n) (or S u for a rotation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct ScaledRow {
    pub lin: Vector,
    pub g_a: Vector,
    pub g_b: Vector,
}

/// A joint in the system: its ends and where its rows are.
#[derive(Clone, Copy, Debug)]
struct Node {
    joint: usize,
    ends: [End; 2],
    first: usize,
    len: usize,
}

/// The factorisation's shape, fixed while the joints and which bodies are free stay the same.
#[derive(Clone, Debug, Default)]
struct Shape {
    /// Elimination order (node indices).
    order: Vec<u32>,
    /// Per position in `order`: its later neighbours, as a range of `later`, and the updates
    /// its elimination makes, as a range of `updates`.
    ranges: Vec<[(u32, u32); 2]>,
    /// (later neighbour, the block B(k, neighbour)), by elimination order.
    later: Vec<(u32, u32)>,
    /// Schur-complement updates: target −= B(k, n1)ᵀ L(k, n2).
    updates: Vec<Update>,
    /// Neighbouring pairs of the joints' graph as given: (block, earlier node, later node).
    touching: Vec<(u32, u32, u32)>,
    /// Number of off-diagonal blocks, fill included.
    blocks: usize,
    /// The nodes with no neighbour (in node order), first in `order`, and the others (in
    /// node order): a lone node's K is its own block, solved without the elimination.
    lone: Vec<u32>,
    linked: Vec<u32>,
}

/// One Schur-complement update of the factorisation.
#[derive(Clone, Copy, Debug)]
struct Update {
    /// Blocks B(k, n1) and L(k, n2), n1 eliminated no later than n2.
    left: u32,
    right: u32,
    n1: u32,
    n2: u32,
    /// The block B(n1, n2) (ignored when n1 = n2: D of n1).
    target: u32,
}

/// The joints' equality rows and their factorised K.
#[derive(Clone, Debug, Default)]
pub(crate) struct JointSystem {
    nodes: Vec<Node>,
    /// The key the shape was built for: each node's joint and free slots.
    key: Vec<(u32, u32, u32)>,
    shape: Shape,
    /// The rows, node after node, and their position errors C.
    pub rows: Vec<ScaledRow>,
    pub error: Vec<Scalar>,
    /// Accumulated impulse of each row this substep.
    pub acc: Vec<Scalar>,
    /// D of each node (factorised in place: unit L below the diagonal, 1/d on it).
    diag: Vec<Block>,
    /// Off-diagonal blocks B(k, n) (k eliminated first), and L(k, n) = D_k⁻¹ B(k, n).
    off: Vec<Block>,
    lower: Vec<Block>,
    rhs: Vec<Scalar>,
}

impl JointSystem {
    /// Sets the nodes: per joint (`rows` its equality-row count, 0 if none) its ends. Builds the
    /// elimination order anew only when the nodes differ from last time.
    pub fn set_nodes(&mut self, ends: &[[End; 2]], rows: impl Iterator<Item = usize>) {
        self.nodes.clear();
        let mut first = 0;
        for (joint, (e, len)) in ends.iter().zip(rows).enumerate() {
            if len > 0 && (e[0].free || e[1].free) {
                self.nodes.push(Node { joint, ends: *e, first, len });
                first += len;
            }
        }
        let slot = |e: &End| if e.free { e.slot } else { u32::MAX };
        let key: Vec<_> = self.nodes.iter().map(|n| (n.len as u32, slot(&n.ends[0]), slot(&n.ends[1]))).collect();
        if key != self.key {
            self.shape = Shape::new(&self.nodes);
            self.key = key;
        }
        self.rows.resize(first, ScaledRow::default());
        self.error.resize(first, 0.0);
        self.acc.resize(first, 0.0);
        self.rhs.resize(first, 0.0);
        self.diag.resize(self.nodes.len(), [0.0; MAX_ROWS * MAX_ROWS]);
        self.off.resize(self.shape.blocks, [0.0; MAX_ROWS * MAX_ROWS]);
        self.lower.resize(self.shape.blocks, [0.0; MAX_ROWS * MAX_ROWS]);
    }

    /// Each node's joint (its index in the scene's joints) and the range of its rows.
    pub fn spans(&self) -> impl Iterator<Item = (usize, std::ops::Range<usize>)> + '_ {
        self.nodes.iter().map(|n| (n.joint, n.first..n.first + n.len))
    }

    /// Factorises K for the current `rows`.
    pub fn factorise(&mut self) {
        for (k, node) in self.nodes.iter().enumerate() {
            let r = &self.rows[node.first..node.first + node.len];
            let d = &mut self.diag[k];
            for i in 0..node.len {
                for j in 0..=i {
                    d[i * MAX_ROWS + j] = k_same(&node.ends, &r[i], &r[j]);
                }
            }
        }
        self.off.iter_mut().for_each(|b| *b = [0.0; MAX_ROWS * MAX_ROWS]);
        for &(b, p, q) in &self.shape.touching {
            let (np, nq) = (&self.nodes[p as usize], &self.nodes[q as usize]);
            let (rp, rq) = (&self.rows[np.first..np.first + np.len], &self.rows[nq.first..nq.first + nq.len]);
            let block = &mut self.off[b as usize];
            for (i, ri) in rp.iter().enumerate() {
                for (j, rj) in rq.iter().enumerate() {
                    block[i * MAX_ROWS + j] = k_across(&np.ends, ri, &nq.ends, rj);
                }
            }
        }
        for &k in &self.shape.lone {
            let d = &mut self.diag[k as usize];
            // Each count its own unrolled copy.
            match self.nodes[k as usize].len {
                3 => ldl(d, 3),
                5 => ldl(d, 5),
                6 => ldl(d, 6),
                m => ldl(d, m),
            }
        }
        let lone = self.shape.lone.len();
        for (pos, &k) in self.shape.order.iter().enumerate().skip(lone) {
            let k = k as usize;
            let m = self.nodes[k].len;
            ldl(&mut self.diag[k], m);
            let [(lo, hi), (ulo, uhi)] = self.shape.ranges[pos];
            for &(n, b) in &self.shape.later[lo as usize..hi as usize] {
                let cols = self.nodes[n as usize].len;
                self.lower[b as usize] = ldl_solve_block(&self.diag[k], m, &self.off[b as usize], cols);
            }
            // The neighbours' own blocks lose what k carried between them (Schur complement).
            for u in &self.shape.updates[ulo as usize..uhi as usize] {
                let (m1, m2) = (self.nodes[u.n1 as usize].len, self.nodes[u.n2 as usize].len);
                let (left, right) = (self.off[u.left as usize], self.lower[u.right as usize]);
                let target =
                    if u.n1 == u.n2 { &mut self.diag[u.n1 as usize] } else { &mut self.off[u.target as usize] };
                subtract_product(target, &left, &right, [m, m1, m2]);
            }
        }
    }

    /// Solves K x = rhs in place (`rhs` in, x out), row after row as `rows`.
    fn solve_in_place(&mut self) {
        let y = &mut self.rhs;
        let lone = self.shape.lone.len();
        for (pos, &k) in self.shape.order.iter().enumerate().skip(lone) {
            let nk = &self.nodes[k as usize];
            let [(lo, hi), _] = self.shape.ranges[pos];
            for &(n, b) in &self.shape.later[lo as usize..hi as usize] {
                let nn = &self.nodes[n as usize];
                let l = &self.lower[b as usize];
                for j in 0..nn.len {
                    let s: Scalar = (0..nk.len).map(|i| l[i * MAX_ROWS + j] * y[nk.first + i]).sum();
                    y[nn.first + j] -= s;
                }
            }
        }
        for (pos, &k) in self.shape.order.iter().enumerate().skip(lone).rev() {
            let nk = &self.nodes[k as usize];
            // Element by element: a slice copy of three to six numbers is a call to memcpy.
            let mut x = [0.0; MAX_ROWS];
            for (xi, yi) in x.iter_mut().zip(&y[nk.first..nk.first + nk.len]) {
                *xi = *yi;
            }
            ldl_solve(&self.diag[k as usize], nk.len, &mut x);
            let [(lo, hi), _] = self.shape.ranges[pos];
            for &(n, b) in &self.shape.later[lo as usize..hi as usize] {
                let nn = &self.nodes[n as usize];
                let l = &self.lower[b as usize];
                for (i, xi) in x[..nk.len].iter_mut().enumerate() {
                    *xi -= (0..nn.len).map(|j| l[i * MAX_ROWS + j] * y[nn.first + j]).sum::<Scalar>();
                }
            }
            for (yi, xi) in y[nk.first..nk.first + nk.len].iter_mut().zip(x) {
                *yi = xi;
            }
        }
    }

    /// One pass: λ = `mass_scale` K⁻¹(−J v − `bias_rate` C) − `impulse_scale` λ_acc for every
    /// row at once (a soft step's spring, or rigid), applied to the bodies. A lone node shares
    /// no body with another, so it is solved whole, on its two bodies gathered once, with the
    /// same arithmetic as the general path (the same bits).
    pub fn pass<B: BodyStore + ?Sized>(&mut self, bodies: &mut B, soft: [Scalar; 3]) {
        for &k in &self.shape.lone {
            let node = self.nodes[k as usize];
            let (d, span) = (&self.diag[k as usize], node.first..node.first + node.len);
            let (rows, error, acc) = (&self.rows[span.clone()], &self.error[span.clone()], &mut self.acc[span]);
            match node.len {
                3 => lone_pass::<B, 3>(bodies, &node.ends, d, rows, error, acc, soft),
                5 => lone_pass::<B, 5>(bodies, &node.ends, d, rows, error, acc, soft),
                6 => lone_pass::<B, 6>(bodies, &node.ends, d, rows, error, acc, soft),
                _ => lone_pass::<B, 1>(bodies, &node.ends, d, rows, error, acc, soft),
            }
        }
        if self.shape.linked.is_empty() {
            return;
        }
        let [bias_rate, mass_scale, impulse_scale] = soft;
        for &k in &self.shape.linked {
            let node = &self.nodes[k as usize];
            for i in node.first..node.first + node.len {
                self.rhs[i] = -(speed(bodies, &node.ends, &self.rows[i]) + bias_rate * self.error[i]);
            }
        }
        self.solve_in_place();
        for &k in &self.shape.linked {
            let node = &self.nodes[k as usize];
            for i in node.first..node.first + node.len {
                let l = mass_scale * self.rhs[i] - impulse_scale * self.acc[i];
                self.acc[i] += l;
                apply(bodies, &node.ends, &self.rows[i], l);
            }
        }
    }

    /// Re-applies the accumulated impulses.
    pub fn warm<B: BodyStore + ?Sized>(&self, bodies: &mut B) {
        for &k in &self.shape.lone {
            let node = &self.nodes[k as usize];
            let span = node.first..node.first + node.len;
            let mut pair = Gathered::new(bodies, &node.ends);
            for (row, &l) in self.rows[span.clone()].iter().zip(&self.acc[span]) {
                pair.apply(&node.ends, row, l);
            }
            pair.store(bodies, &node.ends);
        }
        for &k in &self.shape.linked {
            let node = &self.nodes[k as usize];
            for i in node.first..node.first + node.len {
                apply(bodies, &node.ends, &self.rows[i], self.acc[i]);
            }
        }
    }
}

/// A lone node's two bodies' velocities, read once for a pass and written back after it.
struct Gathered {
    a: (Vector, Vector),
    b: (Vector, Vector),
}

impl Gathered {
    #[inline(always)]
    fn new<B: BodyStore + ?Sized>(bodies: &B, [ea, eb]: &[End; 2]) -> Self {
        let (a, b) = (bodies.body(ea.slot), bodies.body(eb.slot));
        Self { a: (a.v, a.w), b: (b.v, b.w) }
    }

    /// The speed a row measures (as `speed`).
    #[inline(always)]
    fn speed(&self, row: &ScaledRow) -> Scalar {
        row.lin.dot(self.a.0 - self.b.0) + row.g_a.dot(self.a.1) - row.g_b.dot(self.b.1)
    }

    /// Applies impulse `lambda` along a row (as `apply`).
    #[inline(always)]
    fn apply(&mut self, [ea, eb]: &[End; 2], row: &ScaledRow, lambda: Scalar) {
        if ea.free {
            self.a.0 += row.lin * (ea.inv_mass * lambda);
            self.a.1 += row.g_a * lambda;
        }
        if eb.free {
            self.b.0 -= row.lin * (eb.inv_mass * lambda);
            self.b.1 -= row.g_b * lambda;
        }
    }

    #[inline(always)]
    fn store<B: BodyStore + ?Sized>(&self, bodies: &mut B, [ea, eb]: &[End; 2]) {
        if ea.free {
            let a = bodies.body_mut(ea.slot);
            (a.v, a.w) = self.a;
        }
        if eb.free {
            let b = bodies.body_mut(eb.slot);
            (b.v, b.w) = self.b;
        }
    }
}

/// `JointSystem::pass` for a lone node of `M` rows (`M` = 1 stands for any other count: the
/// rows' length is used).
#[inline(always)]
fn lone_pass<B: BodyStore + ?Sized, const M: usize>(
    bodies: &mut B,
    ends: &[End; 2],
    d: &Block,
    rows: &[ScaledRow],
    error: &[Scalar],
    acc: &mut [Scalar],
    [bias_rate, mass_scale, impulse_scale]: [Scalar; 3],
) {
    let m = if M == 1 { rows.len() } else { M };
    let mut pair = Gathered::new(bodies, ends);
    let mut x = [0.0; MAX_ROWS];
    for i in 0..m {
        x[i] = -(pair.speed(&rows[i]) + bias_rate * error[i]);
    }
    ldl_solve(d, m, &mut x);
    for i in 0..m {
        let l = mass_scale * x[i] - impulse_scale * acc[i];
        acc[i] += l;
        pair.apply(ends, &rows[i], l);
    }
    pair.store(bodies, ends);
}

impl Shape {
    /// The elimination order (fewest neighbours first, ties by index) and the blocks it
    /// fills.
    fn new(nodes: &[Node]) -> Self {
        let n = nodes.len();
        let mut by_slot: HashMap<u32, Vec<u32>> = HashMap::new();
        for (k, node) in nodes.iter().enumerate() {
            for e in node.ends.iter().filter(|e| e.free) {
                let list = by_slot.entry(e.slot).or_default();
                if list.last() != Some(&(k as u32)) {
                    list.push(k as u32);
                }
            }
        }
        let mut adj = vec![BTreeSet::new(); n];
        let mut given = BTreeSet::new();
        for list in by_slot.values() {
            for (x, &p) in list.iter().enumerate() {
                for &q in &list[x + 1..] {
                    adj[p as usize].insert(q);
                    adj[q as usize].insert(p);
                    given.insert((p.min(q), p.max(q)));
                }
            }
        }
        let lone: Vec<bool> = adj.iter().map(BTreeSet::is_empty).collect();
        let mut heap: BinaryHeap<_> = (0..n as u32).map(|k| Reverse((adj[k as usize].len(), k))).collect();
        let (mut done, mut order, mut later_of) = (vec![false; n], Vec::with_capacity(n), vec![Vec::new(); n]);
        while let Some(Reverse((degree, k))) = heap.pop() {
            let ku = k as usize;
            if done[ku] || degree != adj[ku].len() {
                continue;
            }
            done[ku] = true;
            order.push(k);
            let near: Vec<u32> = std::mem::take(&mut adj[ku]).into_iter().collect();
            for &p in &near {
                adj[p as usize].remove(&k);
                adj[p as usize].extend(near.iter().copied().filter(|&q| q != p));
            }
            for &p in &near {
                heap.push(Reverse((adj[p as usize].len(), p)));
            }
            later_of[ku] = near;
        }
        let mut position = vec![0u32; n];
        for (pos, &k) in order.iter().enumerate() {
            position[k as usize] = pos as u32;
        }
        let mut index: HashMap<(u32, u32), u32> = HashMap::new();
        let mut shape = Self { order, ..Self::default() };
        let mut near_of = Vec::with_capacity(n);
        for pos in 0..n {
            let k = shape.order[pos];
            let mut near = std::mem::take(&mut later_of[k as usize]);
            near.sort_unstable_by_key(|&q| position[q as usize]);
            for &q in &near {
                let next = index.len() as u32;
                index.entry((k, q)).or_insert(next);
            }
            near_of.push((k, near));
        }
        for (k, near) in near_of {
            let start = (shape.later.len() as u32, shape.updates.len() as u32);
            shape.later.extend(near.iter().map(|&q| (q, index[&(k, q)])));
            for (x, &n1) in near.iter().enumerate() {
                for &n2 in &near[x..] {
                    let target = if n1 == n2 { 0 } else { index[&(n1, n2)] };
                    shape.updates.push(Update { left: index[&(k, n1)], right: index[&(k, n2)], n1, n2, target });
                }
            }
            shape.ranges.push([(start.0, shape.later.len() as u32), (start.1, shape.updates.len() as u32)]);
        }
        for (p, q) in given {
            let (first, second) = if position[p as usize] < position[q as usize] { (p, q) } else { (q, p) };
            shape.touching.push((index[&(first, second)], first, second));
        }
        shape.blocks = index.len();
        (shape.lone, shape.linked) = (0..n as u32).partition(|&k| lone[k as usize]);
        debug_assert!(shape.order.iter().zip(&shape.lone).all(|(a, b)| a == b), "lone nodes come first");
        shape
    }
}

/// K_ij of two rows of one joint: J_i M⁻¹ J_jᵀ.
fn k_same(ends: &[End; 2], p: &ScaledRow, q: &ScaledRow) -> Scalar {
    (ends[0].inv_mass + ends[1].inv_mass) * p.lin.dot(q.lin) + p.g_a.dot(q.g_a) + p.g_b.dot(q.g_b)
}

/// K_ij of rows of two joints, through the free bodies they share (B's end counts negative).
fn k_across(ends_p: &[End; 2], p: &ScaledRow, ends_q: &[End; 2], q: &ScaledRow) -> Scalar {
    let side = |row: &ScaledRow, k: usize| if k == 0 { (1.0, row.g_a) } else { (-1.0, row.g_b) };
    let mut sum = 0.0;
    for (x, ep) in ends_p.iter().enumerate() {
        for (y, eq) in ends_q.iter().enumerate() {
            if ep.free && eq.free && ep.slot == eq.slot {
                let ((sp, gp), (sq, gq)) = (side(p, x), side(q, y));
                sum += sp * sq * (ep.inv_mass * p.lin.dot(q.lin) + gp.dot(gq));
            }
        }
    }
    sum
}

/// The speed a row measures.
fn speed<B: BodyStore + ?Sized>(bodies: &B, ends: &[End; 2], row: &ScaledRow) -> Scalar {
    let (a, b) = (bodies.body(ends[0].slot), bodies.body(ends[1].slot));
    row.lin.dot(a.v - b.v) + row.g_a.dot(a.w) - row.g_b.dot(b.w)
}

/// Applies impulse `lambda` along a row.
fn apply<B: BodyStore + ?Sized>(bodies: &mut B, [ea, eb]: &[End; 2], row: &ScaledRow, lambda: Scalar) {
    if ea.free {
        let a = bodies.body_mut(ea.slot);
        a.v += row.lin * (ea.inv_mass * lambda);
        a.w += row.g_a * lambda;
    }
    if eb.free {
        let b = bodies.body_mut(eb.slot);
        b.v -= row.lin * (eb.inv_mass * lambda);
        b.w -= row.g_b * lambda;
    }
}

/// LDLᵀ of the symmetric `m` × `m` block `a` (its lower triangle), in place: L below the
/// diagonal, 1/d on it, a dropped pivot (`DROP`) as 0 with its column of L.
#[inline(always)]
pub(super) fn ldl(a: &mut Block, m: usize) {
    let mut d = [0.0; MAX_ROWS];
    for j in 0..m {
        let own = a[j * MAX_ROWS + j];
        let dj = own - (0..j).map(|k| a[j * MAX_ROWS + k] * a[j * MAX_ROWS + k] * d[k]).sum::<Scalar>();
        let kept = own > 0.0 && dj > DROP * own;
        d[j] = if kept { dj } else { 0.0 };
        a[j * MAX_ROWS + j] = if kept { 1.0 / dj } else { 0.0 };
        for i in j + 1..m {
            let s =
                a[i * MAX_ROWS + j] - (0..j).map(|k| a[i * MAX_ROWS + k] * a[j * MAX_ROWS + k] * d[k]).sum::<Scalar>();
            a[i * MAX_ROWS + j] = if kept { s / dj } else { 0.0 };
        }
    }
}

/// Solves D x = `x` in place with D factorised by `ldl`.
#[inline(always)]
pub(super) fn ldl_solve(f: &Block, m: usize, x: &mut [Scalar; MAX_ROWS]) {
    for i in 0..m {
        x[i] -= (0..i).map(|k| f[i * MAX_ROWS + k] * x[k]).sum::<Scalar>();
    }
    for i in 0..m {
        x[i] *= f[i * MAX_ROWS + i];
    }
    for i in (0..m).rev() {
        x[i] -= (i + 1..m).map(|k| f[k * MAX_ROWS + i] * x[k]).sum::<Scalar>();
    }
}

/// D⁻¹ B of an `m` × `cols` block B, with D factorised by `ldl`.
fn ldl_solve_block(f: &Block, m: usize, b: &Block, cols: usize) -> Block {
    let mut out = [0.0; MAX_ROWS * MAX_ROWS];
    for c in 0..cols {
        let mut x = [0.0; MAX_ROWS];
        for i in 0..m {
            x[i] = b[i * MAX_ROWS + c];
        }
        ldl_solve(f, m, &mut x);
        for i in 0..m {
            out[i * MAX_ROWS + c] = x[i];
        }
    }
    out
}

/// `target` (m1 × m2) −= `left`ᵀ `right`, both m × (m1 or m2).
fn subtract_product(target: &mut Block, left: &Block, right: &Block, [m, m1, m2]: [usize; 3]) {
    for i in 0..m1 {
        for j in 0..m2 {
            target[i * MAX_ROWS + j] -=
                (0..m).map(|r| left[r * MAX_ROWS + i] * right[r * MAX_ROWS + j]).sum::<Scalar>();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Mat3, Quat};
    use crate::rng::SplitMix64;
    use crate::solver::SolverBody;

    fn vector(rng: &mut SplitMix64) -> Vector {
        Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5)
    }

    /// A system of joints between `bodies` free bodies (slot = index) and the world (slot
    /// `bodies`), each with `rows` random rows.
    fn system(links: &[(u32, Option<u32>, usize)], bodies: u32, rng: &mut SplitMix64) -> JointSystem {
        let end = |slot: Option<u32>, rng: &mut SplitMix64| match slot {
            Some(slot) => End {
                slot,
                free: true,
                inv_mass: 0.5 + rng.unit(),
                scale: Mat3::from_diagonal(Vector::ONE + vector(rng)),
                x0: Vector::ZERO,
                q0: Quat::IDENTITY,
            },
            None => End { slot: bodies, ..End::default() },
        };
        let mut masses: Vec<End> = (0..bodies).map(|b| end(Some(b), rng)).collect();
        masses.push(end(None, rng));
        let ends: Vec<[End; 2]> =
            links.iter().map(|&(a, b, _)| [masses[a as usize], masses[b.unwrap_or(bodies) as usize]]).collect();
        let mut s = JointSystem::default();
        s.set_nodes(&ends, links.iter().map(|l| l.2));
        for row in &mut s.rows {
            *row = ScaledRow { lin: vector(rng), g_a: vector(rng), g_b: vector(rng) };
        }
        s
    }

    /// K as one dense matrix.
    fn dense(s: &JointSystem) -> Vec<Vec<Scalar>> {
        let n = s.rows.len();
        let mut k = vec![vec![0.0; n]; n];
        for p in &s.nodes {
            for q in &s.nodes {
                for i in 0..p.len {
                    for j in 0..q.len {
                        let (ri, rj) = (&s.rows[p.first + i], &s.rows[q.first + j]);
                        k[p.first + i][q.first + j] = if p.first == q.first {
                            k_same(&p.ends, ri, rj)
                        } else {
                            k_across(&p.ends, ri, &q.ends, rj)
                        };
                    }
                }
            }
        }
        k
    }

    #[test]
    fn the_factorised_solve_inverts_k_for_chains_stars_and_loops() {
        let mut rng = SplitMix64::new(3);
        let chain: Vec<_> =
            (0..8).map(|k| (k, if k == 0 { None } else { Some(k - 1) }, [3, 5, 6, 1][k as usize % 4])).collect();
        // A torso (0) with five limbs, two of them two links long, and a ring of three bodies.
        let star = vec![
            (1, Some(0), 3),
            (2, Some(0), 3),
            (3, Some(0), 5),
            (4, Some(0), 3),
            (5, Some(0), 3),
            (6, Some(1), 5),
            (7, Some(2), 5),
            (8, Some(9), 3),
            (9, Some(10), 3),
            (10, Some(8), 1),
            (8, None, 6),
            // Lone: joined to nothing else (to the world, or two bodies of their own).
            (11, None, 3),
            (12, Some(13), 5),
            (14, None, 1),
        ];
        for (links, bodies) in [(chain, 8), (star, 15)] {
            let mut s = system(&links, bodies, &mut rng);
            s.factorise();
            let k = dense(&s);
            let rhs: Vec<Scalar> = (0..s.rows.len()).map(|_| rng.unit() - 0.5).collect();
            s.rhs.copy_from_slice(&rhs);
            s.solve_in_place();
            // The lone nodes are solved by `pass`, on their own block.
            for &k in &s.shape.lone {
                let n = &s.nodes[k as usize];
                let mut x = [0.0; MAX_ROWS];
                x[..n.len].copy_from_slice(&s.rhs[n.first..n.first + n.len]);
                ldl_solve(&s.diag[k as usize], n.len, &mut x);
                s.rhs[n.first..n.first + n.len].copy_from_slice(&x[..n.len]);
            }
            for (i, row) in k.iter().enumerate() {
                let kx: Scalar = row.iter().zip(&s.rhs).map(|(a, x)| a * x).sum();
                assert!((kx - rhs[i]).abs() < 1e-9, "row {i}: {kx} against {}", rhs[i]);
            }
        }
    }

    #[test]
    fn a_rigid_pass_stops_every_equality_row_lone_or_linked() {
        let mut rng = SplitMix64::new(5);
        // Two lone pendulums, a chain of three, a lone rod between two bodies.
        let links = [(0, None, 3), (1, None, 5), (2, None, 3), (3, Some(2), 6), (4, Some(3), 3), (5, Some(6), 1)];
        let mut s = system(&links, 7, &mut rng);
        assert_eq!(s.shape.lone, [0, 1, 5]);
        // The world's end turns nothing (its S is zero), as in the solver.
        for node in &s.nodes {
            if !node.ends[1].free {
                s.rows[node.first..node.first + node.len].iter_mut().for_each(|r| r.g_b = Vector::ZERO);
            }
        }
        s.factorise();
        let mut bodies: Vec<SolverBody> = (0..8)
            .map(|b| {
                if b < 7 {
                    SolverBody { v: vector(&mut rng), w: vector(&mut rng), ..SolverBody::default() }
                } else {
                    SolverBody::default()
                }
            })
            .collect();
        s.pass(bodies.as_mut_slice(), [0.0, 1.0, 0.0]);
        for node in &s.nodes {
            for row in &s.rows[node.first..node.first + node.len] {
                let v = speed(bodies.as_slice(), &node.ends, row);
                assert!(v.abs() < 1e-12, "joint {}: speed {v}", node.joint);
            }
        }
    }
}
