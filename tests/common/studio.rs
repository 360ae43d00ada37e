//! A `rigid studio` started for a test on a free port, and plain HTTP/1.1 requests to it.

use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

pub mod webdriver;

/// A running studio; killed when dropped, also when a test fails.
pub struct Studio {
    child: Child,
    /// `host:port` it serves.
    pub addr: String,
}

impl Drop for Studio {
    /// Ctrl-C first, so the studio removes its upload folder; then, if need be, a kill.
    fn drop(&mut self) {
        let _ = Command::new("kill").args(["-INT", &self.child.id().to_string()]).status();
        let deadline = std::time::Instant::now() + Duration::from_secs(2);
        while std::time::Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `rigid studio SCENE --port 0 --no-open` and reads the address it prints.
pub fn start(scene: &str) -> Studio {
    let mut child = Command::new(env!("CARGO_BIN_EXE_rigid"))
        .args(["studio", scene, "--port", "0", "--no-open"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("rigid starts");
    let stdout = child.stdout.take().expect("stdout");
    let mut studio = Studio { child, addr: String::new() };
    let mut lines = BufReader::new(stdout).lines();
    let line = lines.next().expect("a line").expect("utf-8");
    let at = line.find("http://").unwrap_or_else(|| panic!("no address in {line:?}"));
    studio.addr = line[at + "http://".len()..].trim_end_matches('/').to_string();
    // Keep draining stdout so the server never blocks on a full pipe.
    std::thread::spawn(move || lines.for_each(drop));
    studio
}

/// One request to the studio; returns the status and the body.
pub fn request(studio: &Studio, method: &str, path: &str, body: &[u8]) -> (u16, Vec<u8>) {
    http(&studio.addr, method, path, body)
}

/// One HTTP/1.1 request to `addr` (`host:port`); returns the status and the body.
pub fn http(addr: &str, method: &str, path: &str, body: &[u8]) -> (u16, Vec<u8>) {
    try_http(addr, method, path, body, Duration::from_secs(60))
        .unwrap_or_else(|e| panic!("{method} http://{addr}{path}: {e}"))
}

/// As `http`, but an error instead of a panic (for destructors).
pub fn try_http(addr: &str, method: &str, path: &str, body: &[u8], wait: Duration) -> std::io::Result<(u16, Vec<u8>)> {
    let mut stream = TcpStream::connect(addr)?;
    stream.set_read_timeout(Some(wait))?;
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes())?;
    stream.write_all(body)?;
    // chromedriver keeps the connection open whatever the request says: read up to
    // Content-Length when there is one, else to the end.
    let mut response = Vec::new();
    let mut buffer = [0u8; 65536];
    let (split, length) = loop {
        let n = stream.read(&mut buffer)?;
        if n == 0 {
            return Err(std::io::Error::other("the connection closed before the headers ended"));
        }
        response.extend_from_slice(&buffer[..n]);
        if let Some(split) = response.windows(4).position(|w| w == b"\r\n\r\n") {
            let head = String::from_utf8_lossy(&response[..split]).to_ascii_lowercase();
            let length = head.lines().find_map(|l| l.strip_prefix("content-length:")?.trim().parse::<usize>().ok());
            break (split, length);
        }
    };
    match length {
        Some(length) => {
            while response.len() < split + 4 + length {
                let n = stream.read(&mut buffer)?;
                if n == 0 {
                    break;
                }
                response.extend_from_slice(&buffer[..n]);
            }
        }
        None => {
            stream.read_to_end(&mut response)?;
        }
    }
    let head = String::from_utf8_lossy(&response[..split]).to_string();
    let status =
        head.split(' ').nth(1).and_then(|s| s.parse().ok()).ok_or_else(|| std::io::Error::other("no status"))?;
    let body = response[split + 4..].to_vec();
    if head.to_ascii_lowercase().contains("transfer-encoding: chunked") {
        Ok((status, unchunk(&body)))
    } else {
        Ok((status, body))
    }
}

/// The body of a chunked response (big bodies come so).
fn unchunk(mut body: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let line_end = body.windows(2).position(|w| w == b"\r\n").expect("chunk size line");
        let size_text = String::from_utf8_lossy(&body[..line_end]).to_string();
        let size = usize::from_str_radix(size_text.split(';').next().expect("size").trim(), 16).expect("hex size");
        body = &body[line_end + 2..];
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&body[..size]);
        body = &body[size + 2..];
    }
}

/// `GET path` as JSON, which must answer 200.
pub fn get(studio: &Studio, path: &str) -> Value {
    let (status, body) = request(studio, "GET", path, b"");
    assert_eq!(status, 200, "GET {path}: {}", String::from_utf8_lossy(&body));
    serde_json::from_slice(&body).expect("JSON")
}

/// The `data-testid`s the page is written with (docs/studio.md); the schedule's `system-<name>`
/// checkboxes are made by its script.
pub const PAGE_TEST_IDS: &[&str] = &[
    "viewport",
    "play",
    "pause",
    "step",
    "reset",
    "time",
    "actor-count",
    "scene-file",
    "mesh-file",
    "add-box",
    "add-sphere",
    "add-cylinder",
    "timings",
    "error",
    "actor-name",
    "actor-mass",
    "actor-restitution",
    "actor-friction",
    "actor-velocity",
    "actor-apply",
    "save",
    "show-joints",
    "joint-count",
    "show-contacts",
    "adaptive-scale",
    "render-scale",
];

/// Headless Chromium drawing WebGL on the processor (SwiftShader; no GPU on CI).
pub const CHROMIUM_FLAGS: [&str; 7] = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--use-gl=swiftshader",
    "--enable-unsafe-swiftshader",
    "--no-first-run",
    "--hide-scrollbars",
];
