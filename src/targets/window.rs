//! A desktop window (winit, X11) driven from vergence's own frame loop: it
//! is opened once, its events are pumped once per frame without blocking,
//! and what they mean for the loop — closed, resized, keys and mouse for
//! the fly camera — is kept in [`Input`]. The Vulkan side (surface,
//! swapchain, blit) is `gpu::surface::Presenter`.

use crate::error::{Error, Result};
use crate::gpu::ExtraExtensions;
use ash::vk;
use glam::DVec3;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle, RawDisplayHandle, RawWindowHandle};
use std::collections::HashSet;
use std::time::Duration;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::platform::pump_events::{EventLoopExtPumpEvents, PumpStatus};
use winit::window::{Window as WinitWindow, WindowId};

/// Which eye images a window shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Eyes {
    /// Left and right side by side.
    Both,
    /// The left eye only.
    Left,
    /// The right eye only.
    Right,
}

impl Eyes {
    /// The eye indices shown, left to right.
    pub fn indices(self) -> &'static [usize] {
        match self {
            Eyes::Both => &[0, 1],
            Eyes::Left => &[0],
            Eyes::Right => &[1],
        }
    }
}

/// Fails with the reason when no display server can be reached: neither
/// `DISPLAY` nor `WAYLAND_DISPLAY` is set (this build opens X11 windows,
/// so a Wayland-only session needs XWayland's `DISPLAY`).
pub fn display_available() -> Result<()> {
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    if set("DISPLAY") {
        return Ok(());
    }
    if set("WAYLAND_DISPLAY") {
        return Err(Error::Window(
            "WAYLAND_DISPLAY is set but DISPLAY is not; this build opens X11 windows (start XWayland or set DISPLAY)".into(),
        ));
    }
    Err(Error::Window(
        "no display: neither DISPLAY nor WAYLAND_DISPLAY is set".into(),
    ))
}

/// Keyboard and mouse state gathered from the window's events.
#[derive(Debug, Default)]
pub struct Input {
    /// Keys held down.
    pub held: HashSet<KeyCode>,
    /// Keys pressed since the last [`Window::pump`] (no repeats).
    pub pressed: Vec<KeyCode>,
    /// Mouse movement (pixels) with the left button held since the last pump.
    pub look: (f64, f64),
    /// The window was asked to close (or Escape was pressed).
    pub close: bool,
    /// The window changed size since the last pump.
    pub resized: bool,
    dragging: bool,
    cursor: Option<(f64, f64)>,
}

struct App {
    title: String,
    size: PhysicalSize<u32>,
    window: Option<WinitWindow>,
    error: Option<String>,
    input: Input,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attrs = WinitWindow::default_attributes()
            .with_title(self.title.clone())
            .with_inner_size(self.size);
        match event_loop.create_window(attrs) {
            Ok(w) => self.window = Some(w),
            Err(e) => self.error = Some(format!("cannot open a window: {e}")),
        }
    }

    fn window_event(&mut self, _: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let input = &mut self.input;
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => input.close = true,
            WindowEvent::Resized(_) => input.resized = true,
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        physical_key: PhysicalKey::Code(code),
                        state,
                        repeat,
                        ..
                    },
                is_synthetic,
                ..
            } => match state {
                ElementState::Pressed => {
                    // Synthetic presses (keys found held when the window
                    // gains focus) are no key strokes: they would switch a
                    // toggle twice.
                    let stroke = !repeat && !is_synthetic;
                    if code == KeyCode::Escape && stroke {
                        input.close = true;
                    }
                    if stroke {
                        input.pressed.push(code);
                    }
                    input.held.insert(code);
                }
                ElementState::Released => {
                    input.held.remove(&code);
                }
            },
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => input.dragging = state == ElementState::Pressed,
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let (true, Some(c)) = (input.dragging, input.cursor) {
                    input.look.0 += p.0 - c.0;
                    input.look.1 += p.1 - c.1;
                }
                input.cursor = Some(p);
            }
            WindowEvent::Focused(false) => {
                input.held.clear();
                input.dragging = false;
            }
            _ => {}
        }
    }
}

/// An open window and its event loop.
pub struct Window {
    event_loop: EventLoop<()>,
    app: App,
}

impl Window {
    /// Opens a window of `size` pixels titled `title` (fails with one line
    /// when there is no display).
    pub fn open(title: &str, size: vk::Extent2D) -> Result<Window> {
        display_available()?;
        let event_loop = EventLoop::new().map_err(|e| {
            Error::Window(format!(
                "cannot connect to the display {}: {e}",
                std::env::var("DISPLAY").unwrap_or_default()
            ))
        })?;
        let mut w = Window {
            event_loop,
            app: App {
                title: title.to_string(),
                size: PhysicalSize::new(size.width.max(1), size.height.max(1)),
                window: None,
                error: None,
                input: Input::default(),
            },
        };
        for _ in 0..100 {
            w.pump_events(Some(Duration::from_millis(10)));
            if let Some(e) = w.app.error.take() {
                return Err(Error::Window(e));
            }
            if w.app.window.is_some() {
                return Ok(w);
            }
        }
        Err(Error::Window(
            "the window did not open within a second".into(),
        ))
    }

    fn pump_events(&mut self, timeout: Option<Duration>) {
        if let PumpStatus::Exit(_) = self.event_loop.pump_app_events(timeout, &mut self.app) {
            self.app.input.close = true;
        }
    }

    /// Handles the pending events without waiting and returns the input
    /// gathered since the last call (keys held stay held).
    pub fn pump(&mut self) -> &mut Input {
        let input = &mut self.app.input;
        input.pressed.clear();
        input.look = (0.0, 0.0);
        input.resized = false;
        self.pump_events(Some(Duration::ZERO));
        &mut self.app.input
    }

    /// The input gathered by the last [`Window::pump`].
    pub fn input(&self) -> &Input {
        &self.app.input
    }

    fn window(&self) -> &WinitWindow {
        self.app.window.as_ref().expect("opened in Window::open")
    }

    /// The drawable size in pixels.
    pub fn size(&self) -> vk::Extent2D {
        let s = self.window().inner_size();
        vk::Extent2D {
            width: s.width,
            height: s.height,
        }
    }

    /// Sets the title.
    pub fn set_title(&self, title: &str) {
        self.window().set_title(title);
    }

    /// Asks the window system for a new drawable size.
    pub fn request_size(&self, size: vk::Extent2D) {
        let _ = self
            .window()
            .request_inner_size(PhysicalSize::new(size.width, size.height));
    }

    /// The raw display and window handles, for the Vulkan surface.
    pub fn handles(&self) -> Result<(RawDisplayHandle, RawWindowHandle)> {
        let w = self.window();
        let display = w
            .display_handle()
            .map_err(|e| Error::Window(format!("no display handle: {e}")))?
            .as_raw();
        let window = w
            .window_handle()
            .map_err(|e| Error::Window(format!("no window handle: {e}")))?
            .as_raw();
        Ok((display, window))
    }

    /// The Vulkan extensions a surface on this window needs.
    pub fn extensions(&self) -> Result<ExtraExtensions> {
        let (display, _) = self.handles()?;
        Ok(ExtraExtensions {
            instance: crate::gpu::surface::instance_extensions(display)?,
            device: crate::gpu::surface::device_extensions(),
        })
    }
}

/// A free-flying head for the desktop preview: position, yaw and pitch,
/// moved by WASD (Q/E down/up), turned by dragging with the left mouse
/// button, faster with Shift.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlyCamera {
    /// Head position in metres.
    pub position: DVec3,
    /// Yaw in degrees about +Y.
    pub yaw: f64,
    /// Pitch in degrees about +X (clamped to ±89).
    pub pitch: f64,
}

/// Walking speed in metres per second (×5 with Shift).
pub const FLY_SPEED: f64 = 2.0;
/// Degrees turned per pixel of mouse drag.
pub const LOOK_DEG_PER_PIXEL: f64 = 0.2;

impl FlyCamera {
    /// At `pose` (its yaw and pitch taken from its forward direction).
    pub fn at(pose: crate::view::Pose) -> FlyCamera {
        let f = pose.forward();
        let yaw = (-f.x).atan2(-f.z).to_degrees();
        let pitch = f.y.clamp(-1.0, 1.0).asin().to_degrees();
        FlyCamera {
            position: pose.position,
            yaw,
            pitch,
        }
    }

    /// The head pose.
    pub fn pose(&self) -> crate::view::Pose {
        crate::view::Pose::from_euler_deg(self.position, self.yaw, self.pitch, 0.0)
    }

    /// Applies `dt` seconds of `input`; returns whether the camera moved.
    pub fn update(&mut self, input: &Input, dt: f64) -> bool {
        let before = *self;
        self.yaw -= input.look.0 * LOOK_DEG_PER_PIXEL;
        self.pitch = (self.pitch - input.look.1 * LOOK_DEG_PER_PIXEL).clamp(-89.0, 89.0);
        let held = |k| input.held.contains(&k);
        let axis = |plus, minus| (held(plus) as i32 - held(minus) as i32) as f64;
        let forward = axis(KeyCode::KeyW, KeyCode::KeyS);
        let right = axis(KeyCode::KeyD, KeyCode::KeyA);
        let up = axis(KeyCode::KeyE, KeyCode::KeyQ);
        let fast = held(KeyCode::ShiftLeft) || held(KeyCode::ShiftRight);
        let speed = FLY_SPEED * if fast { 5.0 } else { 1.0 } * dt.clamp(0.0, 0.25);
        let pose = self.pose();
        let f = pose.forward();
        let r = pose.orientation * DVec3::X;
        let step = f * forward + r * right + DVec3::Y * up;
        if step.length_squared() > 0.0 {
            self.position += step.normalize() * speed;
        }
        *self != before
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::Pose;

    #[test]
    fn fly_camera_round_trips_a_pose_and_moves_where_it_looks() {
        let pose = Pose::from_euler_deg(DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0);
        let cam = FlyCamera::at(pose);
        assert!((cam.yaw + 25.0).abs() < 1e-9 && (cam.pitch + 5.0).abs() < 1e-9);
        let p = cam.pose();
        assert!(p.position.distance(pose.position) < 1e-12);
        assert!(p.orientation.dot(pose.orientation).abs() > 1.0 - 1e-12);

        let mut input = Input::default();
        let mut c = cam;
        assert!(!c.update(&input, 0.1), "no input, no motion");
        input.held.insert(KeyCode::KeyW);
        assert!(c.update(&input, 0.2));
        let moved = c.position - cam.position;
        assert!((moved.length() - FLY_SPEED * 0.2).abs() < 1e-9);
        assert!(moved.normalize().dot(pose.forward()) > 0.999);
        input.held.insert(KeyCode::ShiftLeft);
        let start = c.position;
        c.update(&input, 0.2);
        assert!((c.position.distance(start) - FLY_SPEED * 5.0 * 0.2).abs() < 1e-9);
        // A long stall moves at most a quarter second's worth.
        let start = c.position;
        c.update(&input, 3.0);
        assert!((c.position.distance(start) - FLY_SPEED * 5.0 * 0.25).abs() < 1e-9);

        let mut turn = Input {
            look: (-50.0, 1000.0),
            ..Input::default()
        };
        let mut t = cam;
        t.update(&turn, 0.0);
        assert!((t.yaw - (cam.yaw + 10.0)).abs() < 1e-9);
        assert_eq!(t.pitch, -89.0, "pitch is clamped");
        turn.look = (0.0, 0.0);
        assert!(!t.update(&turn, 0.0));
    }

    #[test]
    fn eyes_pick_their_views() {
        assert_eq!(Eyes::Both.indices(), &[0, 1]);
        assert_eq!(Eyes::Left.indices(), &[0]);
        assert_eq!(Eyes::Right.indices(), &[1]);
    }
}
