//! `rigid studio`: a web page showing the scene running in 3-D, live, and the JSON API the page
//! and scripts share (docs/studio.md). The simulation steps on a background thread at real time;
//! HTTP requests (a few worker threads, `tiny_http`) read and change it under one mutex.

mod api;
mod joints;
mod save;

use super::AppError;
use crate::cli::args::StudioArgs;
use crate::scene::SceneDef;
use crate::sim::Sim;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// The name posted scenes go by in error messages and in `/api/state`.
pub(crate) const POSTED_NAME: &str = "<studio>";

/// Steps owed beyond this are dropped: a scene slower than real time plays slower instead of
/// falling ever further behind.
const MAX_OWED_STEPS: f64 = 4.0;

/// Everything the page and the API see, under one mutex.
pub(crate) struct Studio {
    /// The scene as last loaded, plus actors added since.
    pub def: SceneDef,
    /// The path the scene is built with (OBJ paths resolve against its folder).
    pub path: PathBuf,
    /// What `/api/state` calls the scene.
    pub scene_name: String,
    /// The running simulation.
    pub sim: Sim,
    /// Stepping at real time.
    pub running: bool,
    /// Simulated seconds per real second.
    pub speed: f64,
    /// A schedule set through the API, kept across resets and added actors.
    pub schedule: Option<Vec<String>>,
    /// Changes whenever the actors or meshes change, so the page rebuilds its geometry.
    pub version: u64,
    /// The last step error (the run pauses on one).
    pub error: Option<String>,
    /// Where uploaded OBJ files are kept.
    pub mesh_dir: PathBuf,
    /// Measured simulation rate while running [steps/s].
    pub steps_per_second: f64,
    /// Names added actors get when they have none: `added-<n>`.
    pub added: u64,
    /// Edits of actors through `POST /api/actor`, by actor name, applied again on every
    /// rebuild (reset, added actors); a loaded scene clears them.
    pub edits: Vec<(String, save::ActorEdit)>,
}

impl Studio {
    /// A paused studio on `sim`, built from `def` at `path`, uploads kept in `mesh_dir`.
    pub fn new(def: SceneDef, path: PathBuf, scene_name: String, sim: Sim, mesh_dir: PathBuf) -> Self {
        Self {
            def,
            path,
            scene_name,
            sim,
            running: false,
            speed: 1.0,
            schedule: None,
            version: 1,
            error: None,
            mesh_dir,
            steps_per_second: 0.0,
            added: 0,
            edits: Vec::new(),
        }
    }

    /// Rebuilds `sim` from `def` (and the API's schedule, if any).
    pub fn rebuild(&mut self) -> Result<(), String> {
        let mut sim = build_sim(&self.def, &self.path, self.schedule.as_deref(), &self.mesh_dir)?;
        self.apply_edits(&mut sim);
        self.sim = sim;
        self.version += 1;
        self.error = None;
        Ok(())
    }

    /// Applies the recorded edits to a freshly built `sim`.
    pub fn apply_edits(&self, sim: &mut Sim) {
        for (name, edit) in &self.edits {
            // Checked when made; the actor is in every rebuild of the same scene.
            let _ = save::apply(sim, name, edit);
        }
    }

    /// Records an edit of actor `name`, on top of earlier ones.
    pub fn record_edit(&mut self, name: &str, edit: save::ActorEdit) {
        match self.edits.iter_mut().find(|(n, _)| n == name) {
            Some((_, e)) => *e = e.merged(edit),
            None => self.edits.push((name.to_string(), edit)),
        }
    }
}

/// Builds a scene, with `schedule` replacing the scene's when given. Errors are the text the
/// CLI prints, with the upload folder left out of paths.
pub(crate) fn build_sim(
    def: &SceneDef,
    path: &Path,
    schedule: Option<&[String]>,
    mesh_dir: &Path,
) -> Result<Sim, String> {
    let mut sim = crate::scene::build(def, path).map_err(|e| clean_error(&e.to_string(), mesh_dir))?;
    if let Some(names) = schedule {
        sim.schedule = crate::systems::schedule_of(names).map_err(|e| e.to_string())?;
    }
    Ok(sim)
}

/// An error's text without the upload folder: `<studio>:3:5: ...` rather than `/tmp/...`.
pub(crate) fn clean_error(text: &str, mesh_dir: &Path) -> String {
    text.replace(&format!("{}/", mesh_dir.display()), "")
}

pub(crate) type Shared = Arc<Mutex<Studio>>;

/// Locks the studio, recovering from a panicked holder (the state stays usable).
pub(crate) fn lock(shared: &Shared) -> MutexGuard<'_, Studio> {
    shared.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

pub(super) fn studio(args: &StudioArgs) -> Result<(), AppError> {
    let (def, path, text) = super::load_scene_text(args.scene.as_deref())?;
    let mut sim = crate::scene::build_from_text(&def, &path, &text)?;
    super::print_warnings(&mut sim, &path);
    // Created by the first upload: a studio that uploads nothing leaves nothing behind.
    let mesh_dir = std::env::temp_dir().join(format!("rigid-studio-{}", std::process::id()));
    let scene_name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let shared: Shared = Arc::new(Mutex::new(Studio::new(def, path, scene_name, sim, mesh_dir.clone())));

    let server = listen(&args.host, args.port)
        .and_then(|l| tiny_http::Server::from_listener(l, None))
        .map_err(|e| AppError::Usage(format!("cannot listen on {}:{}: {e}", args.host, args.port)))?;
    let addr = server.server_addr().to_ip().map_or_else(|| format!("{}:{}", args.host, args.port), |a| a.to_string());
    let url = format!("http://{addr}/");
    super::outln!("rigid studio: serving {} at {url}", lock(&shared).scene_name);
    super::outln!("press Ctrl-C to stop");
    if !is_loopback(&args.host) {
        eprintln!(
            "warning: listening on {}: the studio is reachable from the network and has no access control",
            args.host
        );
    }
    if !args.no_open {
        open_browser(&url);
    }
    let dir = mesh_dir.clone();
    // Best effort: the uploads go with the process. A second handler (none today) is no error.
    let _ = ctrlc::set_handler(move || {
        let _ = std::fs::remove_dir_all(&dir);
        std::process::exit(0);
    });

    let stop = Arc::new(AtomicBool::new(false));
    let stepper = {
        let shared = Arc::clone(&shared);
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || step_loop(&shared, &stop))
    };
    let server = Arc::new(server);
    let workers: Vec<_> = (0..4)
        .map(|_| {
            let server = Arc::clone(&server);
            let shared = Arc::clone(&shared);
            std::thread::spawn(move || {
                while let Ok(request) = server.recv() {
                    api::handle(request, &shared);
                }
            })
        })
        .collect();
    for w in workers {
        let _ = w.join();
    }
    stop.store(true, Ordering::Relaxed);
    let _ = stepper.join();
    let _ = std::fs::remove_dir_all(&mesh_dir);
    Ok(())
}

/// A listening socket whose connections send without Nagle's delay. tiny_http writes a response's
/// head and body apart, and a keep-alive client acknowledges the head late, so the body's last
/// segment waited ~40 ms for that acknowledgement: every `/api/frame` of a page. Linux hands
/// the listener's TCP_NODELAY down to each accepted connection.
fn listen(host: &str, port: u16) -> Result<std::net::TcpListener, Box<dyn std::error::Error + Send + Sync>> {
    use socket2::{Domain, Protocol, Socket, Type};
    use std::net::ToSocketAddrs;
    let mut last = None;
    for addr in (host, port).to_socket_addrs()? {
        let socket = Socket::new(Domain::for_address(addr), Type::STREAM, Some(Protocol::TCP))?;
        let bound = (|| {
            socket.set_reuse_address(true)?;
            socket.set_tcp_nodelay(true)?;
            socket.bind(&addr.into())?;
            socket.listen(128)
        })();
        match bound {
            Ok(()) => return Ok(socket.into()),
            Err(e) => last = Some(e),
        }
    }
    Err(last.map_or_else(|| format!("{host} names no address").into(), Into::into))
}

fn is_loopback(host: &str) -> bool {
    host == "localhost" || host.parse::<std::net::IpAddr>().is_ok_and(|ip| ip.is_loopback())
}

/// Opens `url` in a browser where there is a desktop to open it on; never fails.
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        Some("open")
    } else if cfg!(windows) {
        None
    } else if std::env::var_os("DISPLAY").is_some() || std::env::var_os("WAYLAND_DISPLAY").is_some() {
        Some("xdg-open")
    } else {
        None
    };
    if let Some(cmd) = opener {
        let _ = std::process::Command::new(cmd)
            .arg(url)
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn();
    }
}

/// Steps the simulation at `speed` × real time while it runs, one step per lock so requests
/// are served between steps.
fn step_loop(shared: &Shared, stop: &AtomicBool) {
    let mut last = Instant::now();
    let mut owed = 0.0_f64;
    let (mut rate_start, mut rate_steps) = (Instant::now(), 0_u64);
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        let elapsed = now.duration_since(last).as_secs_f64();
        last = now;
        let stepped = {
            let mut s = lock(shared);
            if s.running {
                owed = (owed + elapsed * s.speed / s.sim.ctx.dt).min(MAX_OWED_STEPS);
                if owed >= 1.0 {
                    owed -= 1.0;
                    if let Err(e) = s.sim.step() {
                        s.error = Some(e.to_string());
                        s.running = false;
                    }
                    true
                } else {
                    false
                }
            } else {
                owed = 0.0;
                s.steps_per_second = 0.0;
                false
            }
        };
        if stepped {
            rate_steps += 1;
        } else {
            std::thread::sleep(Duration::from_millis(1));
        }
        let window = rate_start.elapsed().as_secs_f64();
        if window >= 1.0 {
            let mut s = lock(shared);
            if s.running {
                s.steps_per_second = rate_steps as f64 / window;
            }
            (rate_start, rate_steps) = (Instant::now(), 0);
        }
    }
}
