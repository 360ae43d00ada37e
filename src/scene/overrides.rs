//! `--set PATH=VALUE` (docs/cli.md "Overrides: --set"): changes one field of a scene's RON
//! text before it is parsed, so every check of `parse` applies to the result. PATH uses the
//! scene's own names (`dt`, `actors[2].restitution`, `actors["ball"].velocity`,
//! `solver.substeps`, `joints[0].motor.speed`); VALUE is one RON value.

use crate::scene::SceneDef;
use crate::sim::Sim;
use crate::sim::context::Params;
use std::path::Path;

/// One step of a path: a field, the k-th element of a list, or the element named so.
#[derive(Clone, Debug, PartialEq)]
pub enum Segment {
    /// `.field` (or the first name).
    Field(String),
    /// `[k]`.
    Index(usize),
    /// `["name"]`.
    Name(String),
}

/// Splits a `--set` argument `PATH=VALUE` into its path and value (as text).
pub fn split(arg: &str) -> Result<(Vec<Segment>, String), String> {
    let (path, rest) = parse_path(arg)?;
    let value = rest.strip_prefix('=').ok_or_else(|| "expected PATH=VALUE, e.g. dt=0.01".to_string())?;
    check_value(value)?;
    Ok((path, value.trim().to_string()))
}

/// Parses the path at the start of `s`; returns it with the rest of `s`.
fn parse_path(s: &str) -> Result<(Vec<Segment>, &str), String> {
    fn ident(s: &str) -> Option<(String, &str)> {
        let n = s.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(s.len());
        (n > 0 && !s.as_bytes()[0].is_ascii_digit()).then(|| (s[..n].to_string(), &s[n..]))
    }
    let (first, mut rest) = ident(s.trim_start()).ok_or_else(|| "PATH must start with a field name".to_string())?;
    let mut path = vec![Segment::Field(first)];
    loop {
        rest = rest.trim_start();
        if let Some(r) = rest.strip_prefix('.') {
            let (name, r) = ident(r).ok_or_else(|| "expected a field name after '.'".to_string())?;
            path.push(Segment::Field(name));
            rest = r;
        } else if let Some(r) = rest.strip_prefix('[') {
            let r = r.trim_start();
            let (seg, r) = if r.starts_with('"') {
                let end = string_end(r.as_bytes(), 0).ok_or_else(|| "unterminated name in [\"...\"]".to_string())?;
                let name: String = ron::from_str(&r[..end]).map_err(|e| format!("bad name {}: {e}", &r[..end]))?;
                (Segment::Name(name), &r[end..])
            } else {
                let n = r.find(|c: char| !c.is_ascii_digit()).unwrap_or(r.len());
                let k = r[..n].parse().map_err(|_| "expected [INDEX] or [\"NAME\"]".to_string())?;
                (Segment::Index(k), &r[n..])
            };
            rest = r.trim_start().strip_prefix(']').ok_or_else(|| "expected ']'".to_string())?;
            path.push(seg);
        } else {
            return Ok((path, rest));
        }
    }
}

/// Shows a path as written.
fn show(path: &[Segment]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            Segment::Field(f) if s.is_empty() => s += f,
            Segment::Field(f) => s += &format!(".{f}"),
            Segment::Index(k) => s += &format!("[{k}]"),
            Segment::Name(n) => s += &format!("[{n:?}]"),
        }
    }
    s
}

/// Checks that `value` is exactly one balanced RON value, with no top-level comma and no
/// comment (either could reach past the field it replaces).
fn check_value(value: &str) -> Result<(), String> {
    let b = value.as_bytes();
    if value.trim().is_empty() {
        return Err("VALUE is empty".into());
    }
    let mut i = 0;
    let mut depth: Vec<u8> = Vec::new();
    while i < b.len() {
        match b[i] {
            b'"' => i = string_end(b, i).ok_or("unterminated string in VALUE")?,
            b'/' if matches!(b.get(i + 1), Some(b'/' | b'*')) => return Err("comments are not allowed in VALUE".into()),
            c @ (b'(' | b'[' | b'{') => {
                depth.push(c);
                i += 1;
            }
            c @ (b')' | b']' | b'}') => {
                let open = match c {
                    b')' => b'(',
                    b']' => b'[',
                    _ => b'{',
                };
                if depth.pop() != Some(open) {
                    return Err(format!("unbalanced '{}' in VALUE", c as char));
                }
                i += 1;
            }
            b',' if depth.is_empty() => {
                return Err("VALUE must be one value; a top-level ',' is not allowed (set one field per --set)".into());
            }
            _ => i += 1,
        }
    }
    if depth.is_empty() { Ok(()) } else { Err("unbalanced brackets in VALUE".into()) }
}

/// Index just past the string literal starting at `b[i]` (`"`), or `None` if unterminated.
fn string_end(b: &[u8], mut i: usize) -> Option<usize> {
    i += 1;
    while i < b.len() {
        match b[i] {
            b'\\' => i += 2,
            b'"' => return Some(i + 1),
            _ => i += 1,
        }
    }
    None
}

/// Skips whitespace and comments.
fn skip_ws(b: &[u8], mut i: usize) -> usize {
    loop {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            // RON block comments nest.
            let mut depth = 0;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    depth += 1;
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else {
            return i;
        }
    }
}

/// Index just past the identifier at `i` (or `i` if none).
fn skip_ident(b: &[u8], mut i: usize) -> usize {
    while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
        i += 1;
    }
    i
}

/// End of the value starting at `i` (after whitespace): stops at a top-level `,` or closing
/// bracket. Errors on unbalanced input.
fn skip_value(b: &[u8], mut i: usize) -> Result<usize, String> {
    let mut depth = 0usize;
    let mut end = i;
    while i < b.len() {
        let j = skip_ws(b, i);
        if j != i {
            i = j;
            continue;
        }
        match b[i] {
            b'"' => i = string_end(b, i).ok_or("unterminated string")?,
            b'\'' => {
                i += 1;
                while i < b.len() && b[i] != b'\'' {
                    i += if b[i] == b'\\' { 2 } else { 1 };
                }
                if i >= b.len() {
                    return Err("unterminated character".into());
                }
                i += 1;
            }
            b'(' | b'[' | b'{' => {
                depth += 1;
                i += 1;
            }
            b')' | b']' | b'}' if depth == 0 => return Ok(end),
            b')' | b']' | b'}' => {
                depth -= 1;
                i += 1;
            }
            b',' if depth == 0 => return Ok(end),
            _ => i += 1,
        }
        end = i;
    }
    if depth == 0 { Ok(end) } else { Err("unbalanced brackets".into()) }
}

/// A struct's fields: (name, value start, value end), and the index of its `)`.
struct Fields {
    fields: Vec<(String, usize, usize)>,
    close: usize,
}

/// The fields of the struct whose value starts at `i`: `Name(...)`, `(...)` or `Some(Name(...))`.
fn struct_at(b: &[u8], i: usize) -> Result<Fields, String> {
    let mut i = i;
    loop {
        i = skip_ws(b, i);
        let id_end = skip_ident(b, i);
        let name = &b[i..id_end];
        i = skip_ws(b, id_end);
        if b.get(i) != Some(&b'(') {
            return Err("is not a struct".into());
        }
        i += 1;
        if name != b"Some" {
            break;
        }
    }
    let mut fields = Vec::new();
    loop {
        i = skip_ws(b, i);
        if b.get(i) == Some(&b')') {
            return Ok(Fields { fields, close: i });
        }
        let id_end = skip_ident(b, i);
        let field = String::from_utf8_lossy(&b[i..id_end]).into_owned();
        let colon = skip_ws(b, id_end);
        if id_end == i || b.get(colon) != Some(&b':') {
            return Err("is not a struct of named fields".into());
        }
        let start = skip_ws(b, colon + 1);
        let end = skip_value(b, start)?;
        fields.push((field, start, end));
        i = skip_ws(b, end);
        match b.get(i) {
            Some(b',') => i += 1,
            Some(b')') => {}
            _ => return Err("is not a struct of named fields".into()),
        }
    }
}

/// The elements (start, end) of the list whose value starts at `i`.
fn list_at(b: &[u8], i: usize) -> Result<Vec<(usize, usize)>, String> {
    let mut i = skip_ws(b, i);
    if b.get(i) != Some(&b'[') {
        return Err("is not a list".into());
    }
    i += 1;
    let mut items = Vec::new();
    loop {
        i = skip_ws(b, i);
        if b.get(i) == Some(&b']') {
            return Ok(items);
        }
        let end = skip_value(b, i)?;
        if end == i {
            return Err("is not a well-formed list".into());
        }
        items.push((i, end));
        i = skip_ws(b, end);
        match b.get(i) {
            Some(b',') => i += 1,
            Some(b']') => {}
            _ => return Err("is not a well-formed list".into()),
        }
    }
}

/// Applies one override to scene text; returns the edited text.
pub fn apply_one(text: &str, path: &[Segment], value: &str) -> Result<String, String> {
    let b = text.as_bytes();
    let mut at = skip_ws(b, 0);
    for (n, seg) in path.iter().enumerate() {
        let here = if n == 0 { "the scene".to_string() } else { show(&path[..n]) };
        let last = n + 1 == path.len();
        match seg {
            Segment::Field(f) => {
                let s = struct_at(b, at).map_err(|e| format!("{here} {e}; cannot take .{f}"))?;
                if let Some(&(_, start, end)) = s.fields.iter().find(|(name, ..)| name == f) {
                    if last {
                        return Ok(format!("{}{value}{}", &text[..start], &text[end..]));
                    }
                    at = start;
                } else {
                    // Missing: insert it, with any missing parent structs as anonymous structs.
                    let mut inserted = value.to_string();
                    for seg in path[n + 1..].iter().rev() {
                        match seg {
                            Segment::Field(g) => inserted = format!("({g}: {inserted})"),
                            _ => return Err(format!("{} is not in the scene; cannot index it", show(&path[..=n]))),
                        }
                    }
                    let entry = format!("{f}: {inserted}");
                    return Ok(match s.fields.last() {
                        None => format!("{}{entry}{}", &text[..s.close], &text[s.close..]),
                        Some(&(_, _, end)) => {
                            let after = skip_ws(b, end);
                            if b[after] == b',' {
                                format!("{} {entry},{}", &text[..=after], &text[after + 1..])
                            } else {
                                format!("{}, {entry}{}", &text[..end], &text[end..])
                            }
                        }
                    });
                }
            }
            Segment::Index(k) => {
                let items = list_at(b, at).map_err(|e| format!("{here} {e}; cannot take [{k}]"))?;
                let &(start, end) = items.get(*k).ok_or_else(|| {
                    format!(
                        "{here}[{k}]: index out of range ({here} has {} elements, 0..={})",
                        items.len(),
                        items.len().saturating_sub(1)
                    )
                })?;
                if last {
                    return Ok(format!("{}{value}{}", &text[..start], &text[end..]));
                }
                at = start;
            }
            Segment::Name(name) => {
                let items = list_at(b, at).map_err(|e| format!("{here} {e}; cannot take [{name:?}]"))?;
                let named = items.iter().find(|&&(start, _)| {
                    struct_at(b, start).is_ok_and(|s| {
                        s.fields.iter().any(|(f, vs, ve)| {
                            f == "name" && ron::from_str::<String>(&text[*vs..*ve]).is_ok_and(|v| v == *name)
                        })
                    })
                });
                let &(start, end) = named.ok_or_else(|| format!("{here} has no element named {name:?}"))?;
                if last {
                    return Ok(format!("{}{value}{}", &text[..start], &text[end..]));
                }
                at = start;
            }
        }
    }
    unreachable!("a path has at least one segment")
}

/// Applies `--set` arguments in order to scene text. Errors name the argument.
pub fn apply(text: &str, sets: &[String]) -> Result<String, String> {
    let mut text = text.to_string();
    for arg in sets {
        let (path, value) = split(arg).map_err(|e| format!("--set {arg}: {e}"))?;
        text = apply_one(&text, &path, &value).map_err(|e| format!("--set {arg}: {e}"))?;
    }
    Ok(text)
}

/// Applies `--set` arguments to scene text and parses the result: `Ok((scene, edited text))`,
/// or the message of the first argument that makes the scene invalid (a scene invalid without
/// any `--set` gives its own error).
pub fn parse_with(text: &str, path: &Path, sets: &[String]) -> Result<(SceneDef, String), SetError> {
    if sets.is_empty() {
        return Ok((crate::scene::parse(text, path)?, text.to_string()));
    }
    let edited = apply(text, sets).map_err(SetError::Set)?;
    match crate::scene::parse(&edited, path) {
        Ok(def) => Ok((def, edited)),
        Err(e) => {
            // Blame the first `--set` after which the scene no longer parses; if it did not
            // parse before any, the file itself is at fault.
            crate::scene::parse(text, path)?;
            for k in 1..=sets.len() {
                let partial = apply(text, &sets[..k]).map_err(SetError::Set)?;
                if let Err(e) = crate::scene::parse(&partial, path) {
                    return Err(SetError::Set(format!("--set {}: {e}", sets[k - 1])));
                }
            }
            Err(e.into())
        }
    }
}

/// Why `parse_with` failed.
#[derive(Debug)]
pub enum SetError {
    /// A `--set` argument is bad (its message names it).
    Set(String),
    /// The scene itself is bad.
    Scene(crate::error::SceneError),
}

impl From<crate::error::SceneError> for SetError {
    fn from(e: crate::error::SceneError) -> Self {
        Self::Scene(e)
    }
}

/// The paths `rigid bench` accepts: its scenes are built in code, so only the step and solver
/// settings can change.
fn bench_path_ok(path: &[Segment]) -> bool {
    match path {
        [Segment::Field(f)] => f == "dt" || f == "gravity",
        [Segment::Field(s), Segment::Field(_)] => s == "solver",
        _ => false,
    }
}

/// Applies `--set` arguments (`dt`, `gravity`, `solver.<field>` only) to a built `Sim`,
/// checking values as a scene's are. Used by `rigid bench`.
pub fn apply_to_sim(sim: &mut Sim, sets: &[String]) -> Result<(), String> {
    if sets.is_empty() {
        return Ok(());
    }
    let mut paths = Vec::new();
    for arg in sets {
        let (path, _) = split(arg).map_err(|e| format!("--set {arg}: {e}"))?;
        if !bench_path_ok(&path) {
            return Err(format!(
                "--set {arg}: bench scenes are built in code; only dt, gravity and solver.<field> can be set"
            ));
        }
        paths.push(path);
    }
    let (def, _) = parse_with("Scene(actors: [])", Path::new("<bench>"), sets).map_err(|e| match e {
        SetError::Set(m) => m,
        SetError::Scene(e) => e.to_string(),
    })?;
    let is = |name: &str| paths.iter().any(|p| matches!(p.last(), Some(Segment::Field(f)) if f == name));
    let top = |name: &str| paths.iter().any(|p| matches!(&p[..], [Segment::Field(f)] if f == name));
    // The scene's own mapping to settings; only the fields set are copied.
    let given = crate::scene::instantiate::params(&def);
    let p: &mut Params = &mut sim.ctx.params;
    if top("dt") {
        sim.ctx.dt = def.dt;
    }
    // A new step gets the substeps it calls for, unless they are set too.
    if top("dt") || is("substeps") {
        p.substeps = given.substeps;
    }
    if top("gravity") {
        p.gravity = given.gravity;
    }
    if is("max_sweeps") {
        p.max_sweeps = given.max_sweeps;
    }
    if is("correction") {
        p.correction = given.correction;
    }
    if is("slop") {
        p.slop = given.slop;
    }
    if is("iterations") {
        p.iterations = given.iterations;
    }
    if is("sleep") {
        p.sleep = given.sleep;
    }
    if is("restitution_threshold") {
        p.restitution_threshold = given.restitution_threshold;
    }
    if is("ccd") {
        p.ccd = given.ccd;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = r#"// a scene, (with, commas) in a comment
Scene(
    dt: 0.02, /* block, ( */
    actors: [
        Actor(name: "floor", shape: Box(size: (8.0, 0.2, 4.0)), fixed: true),
        Actor(name: "b, (\"x\")", shape: Box(size: (1.0, 1.0, 1.0)), position: (0.0, 2.0, 0.0)),
    ],
    joints: [Hinge(name: "h", a: "b, (\"x\")", anchor: (0.0, 1.0, 0.0), axis: (0.0, 0.0, 1.0),
                   motor: Motor(speed: 1.5, max_torque: 200.0))],
)
"#;

    fn set(text: &str, arg: &str) -> Result<SceneDef, String> {
        let edited = apply(text, &[arg.to_string()])?;
        crate::scene::parse(&edited, Path::new("t.ron")).map_err(|e| e.to_string())
    }

    #[test]
    fn paths_parse() {
        let (p, v) = split(r#"actors["a]b"][2].x = (1, 2)"#).unwrap();
        assert_eq!(
            p,
            [
                Segment::Field("actors".into()),
                Segment::Name("a]b".into()),
                Segment::Index(2),
                Segment::Field("x".into())
            ]
        );
        assert_eq!(v, "(1, 2)");
        for bad in ["", "=1", "dt", "dt 1", "actors[x]=1", "actors[1=1", "a..b=1", "1a=2"] {
            assert!(split(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn values_must_be_one_value() {
        for bad in ["0.1, steps: 5", "(1, 2", "1)", "\"x", "1 // c", "/* c */ 1", ""] {
            assert!(split(&format!("dt={bad}")).is_err(), "{bad}");
        }
        assert!(split("gravity=(0.0, -1.62, 0.0)").is_ok());
        assert!(split(r#"actors[0].name="a, b""#).is_ok());
    }

    #[test]
    fn replaces_and_inserts_fields() {
        assert_eq!(set(SCENE, "dt=0.01").unwrap().dt, 0.01);
        assert_eq!(set(SCENE, "gravity=(0.0,-1.62,0.0)").unwrap().gravity, (0.0, -1.62, 0.0));
        assert_eq!(set(SCENE, "steps=7").unwrap().steps, 7);
        let def = set(SCENE, "solver.substeps=8").unwrap();
        assert_eq!(def.solver.substeps, Some(8));
        let def = set(&apply(SCENE, &["solver.substeps=8".into()]).unwrap(), "solver.iterations=3").unwrap();
        assert_eq!((def.solver.substeps, def.solver.iterations), (Some(8), 3));
        let def = set(SCENE, "actors[1].restitution=0.25").unwrap();
        assert_eq!(def.actors[1].restitution, 0.25);
        let def = set(SCENE, r#"actors["b, (\"x\")"].restitution=0.5"#).unwrap();
        assert_eq!(def.actors[1].restitution, 0.5);
        let def = set(SCENE, "actors[0].shape.size=(9.0, 0.2, 4.0)").unwrap();
        assert_eq!(def.actors[0].shape, crate::scene::ShapeDef::Box { size: (9.0, 0.2, 4.0) });
        let edited = apply(SCENE, &["joints[0].motor.speed=3.0".into()]).unwrap();
        assert!(edited.contains("Motor(speed: 3.0, max_torque"));
        set(&edited, "dt=0.01").unwrap();
        // Inserting into an empty struct, and into one without a trailing comma.
        assert_eq!(set("Scene(actors: [])", "dt=0.5").unwrap().dt, 0.5);
        assert_eq!(set("Scene()", "actors=[]").unwrap().actors.len(), 0);
        assert_eq!(set("Scene(actors: [],)", "solver.slop=0.1").unwrap().solver.slop, 0.1);
    }

    #[test]
    fn bad_paths_are_named() {
        let err = |arg: &str| set(SCENE, arg).unwrap_err();
        assert!(err("actors[5].mass=1").contains("index out of range"), "{}", err("actors[5].mass=1"));
        assert!(err(r#"actors["nope"].mass=1"#).contains("no element named \"nope\""));
        assert!(err("bogus=1").contains("bogus"), "{}", err("bogus=1"));
        assert!(err("dt.x=1").contains("not a struct"));
        assert!(err("dt[0]=1").contains("not a list"));
        assert!(err("dt=\"fast\"").contains("dt"));
        assert!(err("dt=0.1, steps: 5").starts_with("--set dt=0.1, steps: 5:"));
    }

    #[test]
    fn bench_sims_take_step_and_solver_settings() {
        let mut sim = Sim::new(1.0 / 60.0, Params::default(), crate::systems::default_schedule());
        let sets: Vec<String> =
            ["dt=0.05", "gravity=(0.0, -1.62, 0.0)", "solver.iterations=5"].map(String::from).into();
        apply_to_sim(&mut sim, &sets).unwrap();
        assert_eq!(sim.ctx.dt, 0.05);
        assert_eq!(sim.ctx.params.gravity, crate::math::Vector::new(0.0, -1.62, 0.0));
        assert_eq!(sim.ctx.params.iterations, 5);
        assert_eq!(sim.ctx.params.substeps, Params::substeps_for(0.05));
        apply_to_sim(&mut sim, &["solver.substeps=8".into(), "dt=0.01".into()]).unwrap();
        assert_eq!((sim.ctx.params.substeps, sim.ctx.dt), (8, 0.01));
        assert!(apply_to_sim(&mut sim, &["actors[0].mass=2".into()]).unwrap_err().contains("only dt, gravity"));
        assert!(apply_to_sim(&mut sim, &["steps=2".into()]).is_err());
        assert!(apply_to_sim(&mut sim, &["solver.iterations=0".into()]).unwrap_err().starts_with("--set solver"));
    }

    #[test]
    fn truncated_or_odd_text_never_panics() {
        let odd = format!("{SCENE} 'x' '\\ é /* ( ");
        for end in (0..odd.len()).filter(|&e| odd.is_char_boundary(e)) {
            for arg in ["dt=1.0", "solver.substeps=8", r#"actors["b"].restitution=0.1"#, "actors[1].mass=2.0"] {
                let _ = apply(&odd[..end], &[arg.to_string()]);
            }
        }
    }

    #[test]
    fn parse_with_blames_the_argument() {
        let sets = ["dt=0.01".to_string(), "dt=-1".to_string()];
        match parse_with(SCENE, Path::new("t.ron"), &sets) {
            Err(SetError::Set(m)) => assert!(m.starts_with("--set dt=-1: "), "{m}"),
            other => panic!("{other:?}"),
        }
        let (def, text) = parse_with(SCENE, Path::new("t.ron"), &sets[..1]).unwrap();
        assert_eq!(def.dt, 0.01);
        assert!(text.contains("dt: 0.01"));
    }
}
