//! A small W3C WebDriver client for the studio's browser tests: Debian's `chromedriver` driving
//! headless `chromium`, over plain HTTP/1.1 and JSON (no async runtime). `CHROMIUM` and
//! `CHROMEDRIVER` name other binaries.

use super::{CHROMIUM_FLAGS, http, try_http};
use serde_json::{Value, json};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// WebDriver's key for an element reference in JSON.
const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

/// One browser at a time: software WebGL on two cores is slow enough alone.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// A chromedriver process with one headless Chromium session; both end when dropped.
pub struct Browser {
    driver: Child,
    addr: String,
    session: String,
    downloads: tempfile::TempDir,
    _turn: MutexGuard<'static, ()>,
}

/// An element of the page, by its WebDriver reference.
#[derive(Clone, Debug)]
pub struct Element(String);

impl Drop for Browser {
    fn drop(&mut self) {
        let end = format!("/session/{}", self.session);
        let _ = try_http(&self.addr, "DELETE", &end, b"", Duration::from_secs(20));
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

/// A free loopback port (the driver binds it right after).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port()
}

impl Browser {
    /// Starts chromedriver and a headless Chromium window of `width` × `height` pixels.
    /// A driver that resets the connection or fails to open a session is started afresh on a
    /// new port, up to three times: on a loaded two-core machine a cold Chromium sometimes
    /// dies starting, and one such start must not fail the suite.
    pub fn start(width: u32, height: u32) -> Browser {
        let turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
        let downloads = tempfile::tempdir().expect("temp dir");
        let mut failures = Vec::new();
        for _ in 0..3 {
            match launch(width, height, downloads.path()) {
                Ok((driver, addr, session)) => return Browser { driver, addr, session, downloads, _turn: turn },
                Err(e) => failures.push(e),
            }
        }
        panic!("no browser session in three tries:\n{}", failures.join("\n"))
    }

    /// One command; returns its `value`, or the driver's error as `Err`.
    fn try_call(&self, method: &str, path: &str, body: Option<Value>) -> Result<Value, String> {
        let body = body.map(|b| b.to_string()).unwrap_or_default();
        let (status, reply) = http(&self.addr, method, path, body.as_bytes());
        let reply: Value = serde_json::from_slice(&reply).map_err(|e| format!("{method} {path}: {e}"))?;
        if status == 200 { Ok(reply["value"].clone()) } else { Err(format!("{method} {path}: {status} {reply}")) }
    }

    fn call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
        self.try_call(method, path, body).unwrap_or_else(|e| panic!("{e}"))
    }

    fn session_call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
        self.call(method, &format!("/session/{}{path}", self.session), body)
    }

    /// A command on the element with `data-testid="id"`, found afresh: the page's script
    /// rebuilds some elements (the schedule's checkboxes), so a found one may go stale.
    fn on(&self, id: &str, method: &str, what: &str, body: Option<Value>) -> Value {
        for _ in 0..10 {
            let path = format!("/session/{}/element/{}{what}", self.session, self.find(id).0);
            match self.try_call(method, &path, body.clone()) {
                Ok(v) => return v,
                Err(e) if e.contains("stale element reference") => continue,
                Err(e) => panic!("{e}"),
            }
        }
        panic!("data-testid={id} keeps going stale")
    }

    /// Navigates to `url` and waits for the page's script to have drawn the schedule.
    pub fn open(&self, url: &str) {
        self.session_call("POST", "/url", Some(json!({"url": url})));
        self.wait_for("the schedule's checkboxes", || self.try_find("system-integrate"));
    }

    /// The element with `data-testid="id"`, if the page has one now.
    pub fn try_find(&self, id: &str) -> Option<Element> {
        let query = json!({"using": "css selector", "value": format!("[data-testid=\"{id}\"]")});
        let found = self.try_call("POST", &format!("/session/{}/element", self.session), Some(query)).ok()?;
        Some(Element(found[ELEMENT].as_str()?.to_string()))
    }

    pub fn find(&self, id: &str) -> Element {
        self.try_find(id).unwrap_or_else(|| panic!("no data-testid={id} in the page"))
    }

    pub fn click(&self, id: &str) {
        self.on(id, "POST", "/click", Some(json!({})));
    }

    /// A mouse click `dx`, `dy` pixels from the centre of element `id`, as a user's.
    pub fn click_at(&self, id: &str, dx: i64, dy: i64) {
        let origin = json!({ ELEMENT: self.find(id).0 });
        let actions = json!({"actions": [{
            "type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
            "actions": [
                {"type": "pointerMove", "duration": 0, "origin": origin, "x": dx, "y": dy},
                {"type": "pointerDown", "button": 0},
                {"type": "pointerUp", "button": 0},
            ],
        }]});
        self.session_call("POST", "/actions", Some(actions));
        self.session_call("DELETE", "/actions", None);
    }

    /// Types `text` into element `id` (for a file input: the path of the file to choose).
    pub fn send_keys(&self, id: &str, text: &str) {
        self.on(id, "POST", "/value", Some(json!({"text": text})));
    }

    /// Empties a text field, then types `text`.
    pub fn fill(&self, id: &str, text: &str) {
        self.on(id, "POST", "/clear", Some(json!({})));
        self.send_keys(id, text);
    }

    pub fn text(&self, id: &str) -> String {
        self.on(id, "GET", "/text", None).as_str().unwrap_or_default().to_string()
    }

    pub fn attribute(&self, id: &str, name: &str) -> Option<String> {
        self.on(id, "GET", &format!("/attribute/{name}"), None).as_str().map(str::to_string)
    }

    /// A property of the element (`value`, `disabled`...), as the page's script sees it.
    pub fn property(&self, id: &str, name: &str) -> Value {
        self.on(id, "GET", &format!("/property/{name}"), None)
    }

    pub fn is_selected(&self, id: &str) -> bool {
        self.on(id, "GET", "/selected", None).as_bool().expect("a boolean")
    }

    /// The element's box in CSS pixels: x, y, width, height.
    pub fn rect(&self, id: &str) -> [f64; 4] {
        let r = self.on(id, "GET", "/rect", None);
        ["x", "y", "width", "height"].map(|k| r[k].as_f64().expect("a number"))
    }

    /// A screenshot of the window, decoded.
    pub fn screenshot(&self) -> image::RgbImage {
        let text = self.session_call("GET", "/screenshot", None);
        let png = base64(text.as_str().expect("base64 text"));
        image::load_from_memory(&png).expect("a PNG").to_rgb8()
    }

    /// The folder the browser saves downloads in.
    pub fn downloads(&self) -> &Path {
        self.downloads.path()
    }

    /// Polls `f` every 100 ms until it gives a value; panics after 30 s naming `what`.
    pub fn wait_for<T>(&self, what: &str, mut f: impl FnMut() -> Option<T>) -> T {
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            if let Some(v) = f() {
                return v;
            }
            assert!(Instant::now() < deadline, "timed out waiting for {what}");
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

/// One chromedriver on a fresh port and one session in it: the driver, its address and the
/// session id, or what went wrong (the driver is then ended).
fn launch(width: u32, height: u32, downloads: &Path) -> Result<(Child, String, String), String> {
    let port = free_port();
    let addr = format!("127.0.0.1:{port}");
    let driver_bin = std::env::var("CHROMEDRIVER").unwrap_or_else(|_| "chromedriver".to_string());
    let mut driver = Command::new(driver_bin)
        .arg(format!("--port={port}"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("chromedriver runs (apt-get install chromium-driver)");
    let mut args: Vec<String> = CHROMIUM_FLAGS.iter().map(|f| f.to_string()).collect();
    args.push(format!("--window-size={width},{height}"));
    let mut options = json!({
        "args": args,
        "prefs": {
            "download.default_directory": downloads.display().to_string(),
            "download.prompt_for_download": false,
        },
    });
    if let Ok(binary) = std::env::var("CHROMIUM") {
        options["binary"] = json!(binary);
    }
    let caps = json!({"capabilities": {"alwaysMatch": {"browserName": "chrome", "goog:chromeOptions": options}}});
    let session = (|| {
        let deadline = Instant::now() + Duration::from_secs(30);
        while TcpStream::connect(&addr).is_err() {
            if Instant::now() >= deadline {
                return Err(format!("chromedriver does not listen on {addr}"));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let body = caps.to_string();
        let (status, reply) = try_http(&addr, "POST", "/session", body.as_bytes(), Duration::from_secs(60))
            .map_err(|e| format!("POST http://{addr}/session: {e}"))?;
        let reply: Value = serde_json::from_slice(&reply).map_err(|e| format!("POST /session: {e}"))?;
        match reply["value"]["sessionId"].as_str() {
            Some(id) if status == 200 => Ok(id.to_string()),
            _ => Err(format!("POST /session: {status} {reply}")),
        }
    })();
    match session {
        Ok(id) => Ok((driver, addr, id)),
        Err(e) => {
            let _ = driver.kill();
            let _ = driver.wait();
            Err(e)
        }
    }
}

/// Standard base64 (RFC 4648, with padding), as WebDriver sends screenshots.
fn base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {:?}", c as char),
    };
    let digits: Vec<u8> = text.bytes().filter(|&c| c != b'=' && !c.is_ascii_whitespace()).map(value).collect();
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        let n = chunk.iter().enumerate().fold(0u32, |n, (i, &d)| n | u32::from(d) << (18 - 6 * i));
        out.extend_from_slice(&n.to_be_bytes()[1..chunk.len()]);
    }
    out
}

/// A path as the file input's send-keys wants it: absolute.
pub fn absolute(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
