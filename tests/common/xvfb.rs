//! An Xvfb server per test, shared by the window and mirror tests: its own
//! display number, every inherited descriptor closed in the server, killed
//! when dropped (also when a test fails while it starts), and the xdotool
//! and X11 calls the tests script the windows with.

use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// An Xvfb server on its own display number, killed when dropped (also
/// when the test fails while it starts).
pub struct Xvfb {
    child: Child,
    /// The display, e.g. ":1234".
    pub display: String,
}

impl Xvfb {
    /// Starts one, or returns None (printing why) when Xvfb is missing.
    pub fn start(test: &str) -> Option<Xvfb> {
        if !super::on_path("Xvfb") {
            println!("skipping {test}: Xvfb is not installed (apt-get install xvfb)");
            return None;
        }
        let salt = test
            .bytes()
            .fold(0u32, |a, b| a.wrapping_mul(31) ^ b as u32);
        let n = 3300 + (std::process::id() ^ salt) % 3000;
        let display = format!(":{n}");
        let mut cmd = Command::new("Xvfb");
        cmd.args([&display, "-screen", "0", "1280x720x24"])
            .args(["-nolisten", "tcp", "-noreset"])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null());
        #[cfg(unix)]
        {
            use std::os::unix::process::CommandExt as _;
            // SAFETY: only async-signal-safe close() calls between fork and
            // exec: the server keeps no descriptor this process inherited
            // (a lock a build tool holds, say) should it outlive the test.
            unsafe {
                cmd.pre_exec(|| {
                    for fd in 3..1024 {
                        libc::close(fd);
                    }
                    Ok(())
                });
            }
        }
        let x = Xvfb {
            child: cmd.spawn().expect("Xvfb starts"),
            display,
        };
        // Ready when a client can connect: the socket file alone can exist
        // before the server accepts (or be left over from an earlier one).
        let start = Instant::now();
        while x11rb::connect(Some(&x.display)).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "Xvfb {} did not come up",
                x.display
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        Some(x)
    }

    /// Runs xdotool on this display; a spawn that fails (seen once on a
    /// loaded two-core machine) is retried for up to five seconds.
    pub fn xdotool(&self, args: &[&str]) -> Output {
        let start = Instant::now();
        loop {
            match Command::new("xdotool")
                .env("DISPLAY", &self.display)
                .args(args)
                .output()
            {
                Ok(out) => return out,
                Err(e) if start.elapsed() < Duration::from_secs(5) => {
                    eprintln!("xdotool did not start ({e}); retrying");
                    std::thread::sleep(Duration::from_millis(200));
                }
                Err(e) => panic!("xdotool does not start: {e}"),
            }
        }
    }

    /// The id of the first window whose name matches `name`, waiting up to
    /// three minutes for it (a loaded two-core machine starts slowly);
    /// None if `child` ended first.
    pub fn window(&self, name: &str, child: &mut Child) -> Option<u32> {
        let start = Instant::now();
        loop {
            let out = self.xdotool(&["search", "--name", name]);
            let id = String::from_utf8_lossy(&out.stdout)
                .lines()
                .next()
                .and_then(|l| l.trim().parse().ok());
            if id.is_some() {
                return id;
            }
            if child.try_wait().expect("child state").is_some() {
                return None;
            }
            if start.elapsed() > Duration::from_secs(180) {
                let out = self.xdotool(&["search", "--name", "vergence"]);
                let titles: Vec<String> = String::from_utf8_lossy(&out.stdout)
                    .lines()
                    .map(|id| {
                        let t = self.xdotool(&["getwindowname", id.trim()]);
                        String::from_utf8_lossy(&t.stdout).trim().to_string()
                    })
                    .collect();
                let _ = child.kill();
                let mut log = String::new();
                use std::io::Read as _;
                if let Some(mut o) = child.stdout.take() {
                    let _ = o.read_to_string(&mut log);
                }
                if let Some(mut e) = child.stderr.take() {
                    let _ = e.read_to_string(&mut log);
                }
                panic!(
                    "no window '{name}' appeared within 180 s (vergence windows: {titles:?}); its output:\n{log}"
                );
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Types `key` into window `id` (through XTEST; no window manager
    /// runs, so the window is focused first).
    pub fn key(&self, id: u32, key: &str) {
        let id = id.to_string();
        self.xdotool(&["windowfocus", &id]);
        self.xdotool(&["mousemove", "--window", &id, "20", "20"]);
        assert!(
            self.xdotool(&["key", key]).status.success(),
            "xdotool key {key}"
        );
    }

    /// Holds `key` down in window `id` for `hold`, then lets it go.
    pub fn hold(&self, id: u32, key: &str, hold: Duration) {
        let id = id.to_string();
        self.xdotool(&["windowfocus", &id]);
        self.xdotool(&["mousemove", "--window", &id, "20", "20"]);
        assert!(
            self.xdotool(&["keydown", key]).status.success(),
            "xdotool keydown {key}"
        );
        std::thread::sleep(hold);
        assert!(
            self.xdotool(&["keyup", key]).status.success(),
            "xdotool keyup {key}"
        );
    }

    /// Asks window `id` to close as a window manager does: a
    /// WM_PROTOCOLS client message carrying WM_DELETE_WINDOW.
    pub fn close(&self, id: u32) {
        use x11rb::connection::Connection as _;
        use x11rb::protocol::xproto::{ClientMessageEvent, ConnectionExt as _, EventMask};
        let (conn, _) = x11rb::connect(Some(&self.display)).expect("X connection");
        let atom = |name: &[u8]| {
            conn.intern_atom(false, name)
                .expect("intern_atom")
                .reply()
                .expect("atom")
                .atom
        };
        let (protocols, delete) = (atom(b"WM_PROTOCOLS"), atom(b"WM_DELETE_WINDOW"));
        let event = ClientMessageEvent::new(32, id, protocols, [delete, 0, 0, 0, 0]);
        conn.send_event(false, id, EventMask::NO_EVENT, event)
            .expect("send_event");
        conn.flush().expect("flush");
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
