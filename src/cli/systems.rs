//! `rigid systems`: the default schedule, and on a terminal every shipped system with what it
//! does, the default schedule's marked `*` in run order.

use super::{AppError, outln};
use crate::systems::{DEFAULT_ORDER, REGISTRY};
use std::io::IsTerminal;

/// One line on each shipped system.
const ABOUT: &[(&str, &str)] = &[
    ("cull", "candidate pairs from overlapping bounding spheres (uniform grid)"),
    ("cull_all_pairs", "the same pairs by the paper's all-pairs loop, O(N²): a reference"),
    ("prune", "drops candidates a separating axis proves apart (an early-out)"),
    ("face", "the paper's face test: triangle centroids inside the other body"),
    ("vertex", "the paper's vertex test: vertices inside the other body"),
    ("edge", "the paper's edge test: edges crossing the other body"),
    ("gravity", "v += g·dt for every free body"),
    ("resolve", "the corrected impulse for each impact (no gravity, no friction)"),
    ("solve", "resting contact, friction, impacts under gravity, and joints (the contact solver)"),
    ("correct", "pushes remaining penetration out along the contact normal"),
    ("sleep", "still bodies stop being simulated until touched (off unless solver.sleep)"),
    ("ccd", "fast bodies swept to their time of impact, so none passes through another"),
    ("integrate", "poses from velocities; angular momentum kept in free flight"),
];

/// On a terminal (or with `--all`), every shipped system with a line on each, the default
/// schedule's marked; into a pipe, the default schedule's names one a line, for scripts
/// (docs/cli.md).
pub(super) fn list(all: bool) -> Result<(), AppError> {
    let lines = if all || std::io::stdout().is_terminal() {
        annotated()
    } else {
        DEFAULT_ORDER.iter().map(|n| (*n).to_string()).collect()
    };
    for line in lines {
        outln!("{line}");
    }
    Ok(())
}

fn annotated() -> Vec<String> {
    let about = |name: &str| ABOUT.iter().find(|(n, _)| *n == name).map_or("", |(_, a)| a);
    let mut out = vec!["default schedule (*), in run order:".to_string()];
    out.extend(DEFAULT_ORDER.iter().enumerate().map(|(k, name)| format!("* {:>2}. {name:<15} {}", k + 1, about(name))));
    out.push("other shipped systems (use with --schedule or a scene's `schedule`):".to_string());
    let others = REGISTRY.iter().filter(|s| !DEFAULT_ORDER.contains(&s.name));
    out.extend(others.map(|s| format!("       {:<15} {}", s.name, about(s.name))));
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_shipped_system_has_a_line() {
        for system in super::REGISTRY {
            assert!(super::ABOUT.iter().any(|(n, _)| *n == system.name), "{} has no line", system.name);
        }
    }

    #[test]
    fn the_annotated_list_names_every_system_once_and_marks_the_defaults() {
        let lines = super::annotated();
        for system in super::REGISTRY {
            let column = format!(" {:<15} ", system.name);
            let line = lines.iter().filter(|l| l.contains(&column)).collect::<Vec<_>>();
            assert_eq!(line.len(), 1, "{}: {line:?}", system.name);
            assert_eq!(line[0].starts_with('*'), super::DEFAULT_ORDER.contains(&system.name), "{}", line[0]);
        }
    }
}
