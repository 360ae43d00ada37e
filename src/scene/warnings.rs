//! Warnings for scenes that will misbehave (issue #7): actors that start overlapping, and,
//! without continuous collision, actors fast enough to tunnel (docs/physics.md §5). `rigid
//! check` and `rigid run` print them; they do not stop a run.

use crate::math::Scalar;
use crate::sim::Sim;

/// Overlap depth below which two actors count as touching, not overlapping, relative to the
/// thinner one: touching starts are intended (a Newton's cradle).
pub const OVERLAP_TOLERANCE: Scalar = 1e-6;
/// Safe travel per step as a fraction of the thinnest actor (docs/physics.md §5: beyond about a
/// quarter the closest face can be the far one, the normal flips and the body passes through).
pub const TUNNEL_FRACTION: Scalar = 0.25;

/// The warnings for the initial state of `sim`, worded for the user. Runs the detection
/// systems on the initial state; the sim's clock and counts are left as they were.
#[must_use]
pub fn scene_warnings(sim: &mut Sim) -> Vec<String> {
    let mut out: Vec<String> = schedule_order(&sim.schedule.names()).into_iter().collect();
    out.extend(overlaps(sim));
    out.extend(tunnelling(sim));
    out
}

/// Systems that find or answer contacts, which the paper's order runs before `integrate`.
const BEFORE_INTEGRATE: [&str; 8] = ["cull", "cull_all_pairs", "prune", "face", "vertex", "edge", "resolve", "solve"];

/// A warning when a schedule runs `integrate` before a contact stage: contacts are then found
/// and answered for poses the step has already moved on from, one step late.
#[must_use]
pub fn schedule_order(names: &[&str]) -> Option<String> {
    let integrate = names.iter().position(|n| *n == "integrate")?;
    let late: Vec<&str> = names[integrate..].iter().copied().filter(|n| BEFORE_INTEGRATE.contains(n)).collect();
    (!late.is_empty()).then(|| {
        format!(
            "schedule: 'integrate' runs before {}: contacts are found and answered a step late, so bodies \
             sink into each other (the default order is {})",
            late.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", "),
            crate::systems::DEFAULT_ORDER.join(", ")
        )
    })
}

fn overlaps(sim: &mut Sim) -> Vec<String> {
    let ctx = &mut sim.ctx;
    ctx.begin_step(&sim.world);
    for name in ["cull", "prune", "face", "vertex", "edge"] {
        let system = crate::systems::find(name).expect("shipped systems exist");
        (system.run)(&mut sim.world, ctx);
    }
    let names = &sim.names;
    let mut out = Vec::new();
    for pair in &ctx.pairs {
        let Some(c) = pair.contact() else { continue };
        let (a, b) = (pair.a as usize, pair.b as usize);
        let thin = ctx.bodies.thinner(&ctx.meshes, a, b);
        if c.depth > OVERLAP_TOLERANCE * thin {
            out.push(format!("actors '{}' and '{}' start overlapping by {:.3e} m", names[a], names[b], c.depth));
        }
    }
    ctx.pairs.clear();
    ctx.stats = crate::sim::context::StepStats::default();
    ctx.step -= 1; // the detection pass above is not a step
    out
}

/// Only for the discrete model (`solver.ccd: false`): with continuous collision no body passes
/// through another (docs/physics.md §6.7).
fn tunnelling(sim: &Sim) -> Vec<String> {
    if sim.ctx.params.ccd {
        return Vec::new();
    }
    let b = &sim.ctx.bodies;
    let thinnest = (0..b.len()).map(|i| sim.ctx.meshes.get(b.mesh[i]).thickness).fold(Scalar::INFINITY, Scalar::min);
    let limit = TUNNEL_FRACTION * thinnest;
    let names = sim.names();
    (0..b.len())
        .filter(|&i| !b.is_fixed(i))
        .filter_map(|i| {
            let travel = (b.velocity[i].length() + b.angular_velocity[i].length() * b.radius[i]) * sim.ctx.dt;
            (travel > limit).then(|| {
                format!(
                    "actor '{}' moves {travel:.3e} m per step, more than a quarter of the thinnest actor ({thinnest:.3e} m): \
                     it may pass through others; lower dt or the speed",
                    names[i]
                )
            })
        })
        .collect()
}
