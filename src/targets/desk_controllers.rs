//! Controllers from the desk: with `run --desk-controllers`, keys held in
//! the mirror window drive the two controllers of Monado's remote driver
//! ([`crate::xr::remote`]), so every interaction can be tried at a desk
//! under Monado before a headset arrives. The head stays standing at the
//! tracking origin (locomotion moves the visitor).
//!
//! | key | controller |
//! |---|---|
//! | W A S D | left stick (walk) |
//! | J L | right stick left, right (turn) |
//! | I, then release | right stick forward (the teleport arc; released, teleports) |
//! | Space | right trigger (select, measure, section, panel buttons) |
//! | G | right grip |
//! | M | menu (opens the panel) |
//! | C | right stick click (next viewpoint) |
//! | arrow keys | turn the right hand (90° a second): where it points |

use super::rehearse::{head_of, pose};
use crate::error::{Error, Result};
use crate::xr::remote::{self, RemoteController};
use std::collections::HashSet;
use std::net::TcpStream;
use std::time::{Duration, Instant};
use winit::keyboard::KeyCode;

/// How fast the arrow keys turn the right hand, degrees a second.
const AIM_DEG_PER_S: f64 = 90.0;
/// The farthest the right hand pitches, degrees.
const MAX_PITCH_DEG: f64 = 89.0;

/// The keys' state sent to the remote driver each frame.
pub struct DeskControllers {
    stream: Option<TcpStream>,
    /// The right hand's yaw and pitch, degrees (arrow keys).
    aim: [f64; 2],
    last: Option<Instant>,
}

/// The two controllers for the keys `held` and the right hand's `aim`
/// (yaw, pitch in degrees); both hands rest at the hips.
pub fn hands(held: &HashSet<KeyCode>, aim: [f64; 2]) -> [RemoteController; 2] {
    let on = |k: KeyCode| held.contains(&k);
    let axis = |plus: KeyCode, minus: KeyCode| {
        f32::from(u8::from(on(plus))) - f32::from(u8::from(on(minus)))
    };
    let mut left = RemoteController::at(pose([-0.2, 1.0, -0.3], 0.0, 0.0));
    left.thumbstick = [
        axis(KeyCode::KeyD, KeyCode::KeyA),
        axis(KeyCode::KeyW, KeyCode::KeyS),
    ];
    let mut right = RemoteController::at(pose([0.2, 1.0, -0.3], aim[0], aim[1]));
    right.thumbstick = [
        axis(KeyCode::KeyL, KeyCode::KeyJ),
        axis(KeyCode::KeyI, KeyCode::KeyK),
    ];
    right.trigger = f32::from(u8::from(on(KeyCode::Space)));
    right.squeeze = f32::from(u8::from(on(KeyCode::KeyG)));
    right.b_click = on(KeyCode::KeyM);
    right.thumbstick_click = on(KeyCode::KeyC);
    [left, right]
}

/// The right hand's aim after `dt` seconds with the arrow keys `held`.
pub fn turned(aim: [f64; 2], held: &HashSet<KeyCode>, dt: f64) -> [f64; 2] {
    let on = |k: KeyCode| f64::from(u8::from(held.contains(&k)));
    let step = AIM_DEG_PER_S * dt.clamp(0.0, 0.25);
    let yaw = aim[0] + step * (on(KeyCode::ArrowLeft) - on(KeyCode::ArrowRight));
    let pitch = aim[1] + step * (on(KeyCode::ArrowUp) - on(KeyCode::ArrowDown));
    [
        (yaw + 180.0).rem_euclid(360.0) - 180.0,
        pitch.clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG),
    ]
}

impl Default for DeskControllers {
    fn default() -> Self {
        DeskControllers::new()
    }
}

impl DeskControllers {
    /// Not connected yet: the first [`DeskControllers::step`] connects.
    pub fn new() -> DeskControllers {
        DeskControllers {
            stream: None,
            aim: [0.0; 2],
            last: None,
        }
    }

    /// Sends the controllers for the keys `held` (connecting first, for up
    /// to 10 s); an error when the remote driver cannot be reached or goes
    /// away.
    pub fn step(&mut self, held: &HashSet<KeyCode>) -> Result<()> {
        let now = Instant::now();
        let dt = self.last.map_or(0.0, |t| (now - t).as_secs_f64());
        self.last = Some(now);
        self.aim = turned(self.aim, held, dt);
        let stream = match &mut self.stream {
            Some(s) => s,
            None => {
                let unreachable = |e: std::io::Error| {
                    Error::config(
                        "--desk-controllers",
                        format!(
                            "cannot reach Monado's remote driver on 127.0.0.1:{} ({e}); start monado-service with P_OVERRIDE_ACTIVE_CONFIG=remote",
                            remote::PORT
                        ),
                    )
                };
                let s = remote::connect(Duration::from_secs(10)).map_err(unreachable)?;
                // Sent from the frame loop: draining what the driver sent
                // must not wait (a blocking read waits out its 200 ms
                // timeout every frame).
                s.set_nonblocking(true).map_err(unreachable)?;
                self.stream.insert(s)
            }
        };
        let head = head_of(pose([0.0, 1.6, 0.0], 0.0, 0.0));
        let packet = remote::encode_with(&head, hands(held, self.aim).map(Some));
        remote::send_packet(stream, &packet).map_err(|e| {
            Error::config(
                "--desk-controllers",
                format!("the remote driver closed the connection: {e}"),
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(k: &[KeyCode]) -> HashSet<KeyCode> {
        k.iter().copied().collect()
    }

    #[test]
    fn keys_map_to_sticks_and_buttons() {
        let h = hands(
            &keys(&[
                KeyCode::KeyW,
                KeyCode::KeyA,
                KeyCode::KeyL,
                KeyCode::Space,
                KeyCode::KeyM,
            ]),
            [0.0; 2],
        );
        assert_eq!(h[0].thumbstick, [-1.0, 1.0]);
        assert_eq!(h[1].thumbstick, [1.0, 0.0]);
        assert_eq!((h[1].trigger, h[1].squeeze, h[1].b_click), (1.0, 0.0, true));
        let idle = hands(&keys(&[]), [0.0; 2]);
        assert_eq!(idle[0].thumbstick, [0.0; 2]);
        assert_eq!(idle[1].trigger, 0.0);
        // Opposite keys cancel.
        let both = hands(&keys(&[KeyCode::KeyW, KeyCode::KeyS]), [0.0; 2]);
        assert_eq!(both[0].thumbstick, [0.0; 2]);
    }

    #[test]
    fn arrows_turn_the_right_hand_and_pitch_stops_short_of_the_poles() {
        let down = keys(&[KeyCode::ArrowDown]);
        let a = turned([0.0; 2], &down, 0.2);
        assert_eq!(a, [0.0, -18.0]);
        let mut b = a;
        for _ in 0..100 {
            b = turned(b, &down, 0.25);
        }
        assert_eq!(b[1], -MAX_PITCH_DEG);
        // A stall does not swing the hand around.
        assert_eq!(
            turned([0.0; 2], &keys(&[KeyCode::ArrowLeft]), 10.0),
            [22.5, 0.0]
        );
        // Pitch −90° points the hand's −Z straight down.
        let p = pose([0.0; 3], 0.0, -90.0);
        let o = p.orientation.map(f64::from);
        let dir = glam::DQuat::from_xyzw(o[0], o[1], o[2], o[3]) * glam::DVec3::NEG_Z;
        assert!((dir - glam::DVec3::NEG_Y).length() < 1e-6);
    }
}
