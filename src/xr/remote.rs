//! Client for Monado's remote driver (`P_OVERRIDE_ACTIVE_CONFIG=remote`):
//! one TCP connection on loopback port [`PORT`]; each packet is the whole
//! `struct r_remote_data` of Monado's `drivers/remote/r_interface.h`
//! (header "mndrmt3\0"), 376 bytes, little endian, and the last packet
//! stays in effect. Layout (byte offsets):
//!
//! - 0: u64 header
//! - 8: head: 2 views × 48 bytes {fov: left, right, up, down (f32);
//!   pose: orientation x, y, z, w, position x, y, z (f32); u32 pad}
//! - 104: head centre pose (28 bytes); 132: bool per_view_data_valid + 3 pad
//! - 136: left controller (120 bytes); 256: right controller (120 bytes),
//!   `struct r_remote_controller_data` (checked against Monado 25's
//!   `src/xrt/drivers/remote/r_interface.h`): pose @0 (orientation x, y,
//!   z, w — a unit quaternion — then position x, y, z), linear velocity
//!   @28, angular velocity @40, hand_curl[5] @52, trigger_value @72,
//!   squeeze_value @76, squeeze_force @80, thumbstick x, y @84,
//!   trackpad_force @92, trackpad x, y @96, then one byte each from @104:
//!   hand_tracking_active, active, system_click, system_touch, a_click,
//!   a_touch, b_click, b_touch, trigger_click, trigger_touch,
//!   thumbstick_click, thumbstick_touch, trackpad_touch, 3 bytes padding.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// The remote driver's TCP port on loopback.
pub const PORT: u16 = 4242;

/// Size of `struct r_remote_data`.
pub const PACKET_SIZE: usize = 376;
const HEAD_AT: usize = 8;
const VIEW_SIZE: usize = 48;
const CENTER_AT: usize = HEAD_AT + 2 * VIEW_SIZE;
const PER_VIEW_VALID_AT: usize = CENTER_AT + 28;
const CONTROLLERS_AT: [usize; 2] = [136, 256];
const CONTROLLER_SIZE: usize = 120;
const TRIGGER_AT: usize = 72;
const SQUEEZE_AT: usize = 76;
const THUMBSTICK_AT: usize = 84;
const BOOLS_AT: usize = 104;
/// Byte index of each bool after [`BOOLS_AT`].
const ACTIVE: usize = 1;
const B_CLICK: usize = 6;
const TRIGGER_CLICK: usize = 8;
const THUMBSTICK_CLICK: usize = 10;

/// One controller's state (an Index controller to the runtime).
#[derive(Clone, Copy, Debug)]
pub struct RemoteController {
    /// Pose in the tracking space.
    pub pose: RemotePose,
    /// Trigger, 0..1 (trigger_click follows it above 0.5).
    pub trigger: f32,
    /// Squeeze, 0..1.
    pub squeeze: f32,
    /// Thumbstick x (right), y (forward), −1..1.
    pub thumbstick: [f32; 2],
    /// Thumbstick click.
    pub thumbstick_click: bool,
    /// B button (vergence's menu on Index).
    pub b_click: bool,
}

impl RemoteController {
    /// A tracked, idle controller at `pose`.
    pub fn at(pose: RemotePose) -> RemoteController {
        RemoteController {
            pose,
            trigger: 0.0,
            squeeze: 0.0,
            thumbstick: [0.0; 2],
            thumbstick_click: false,
            b_click: false,
        }
    }
}

fn put_f32(buf: &mut [u8], at: usize, v: f32) {
    buf[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

/// Encodes `head` and the controllers (None: not tracked) as one packet.
pub fn encode_with(
    head: &RemoteHead,
    controllers: [Option<RemoteController>; 2],
) -> [u8; PACKET_SIZE] {
    let mut b = encode(head);
    for (at, c) in CONTROLLERS_AT.into_iter().zip(controllers) {
        let Some(c) = c else { continue };
        put_pose(&mut b, at, &c.pose);
        put_f32(&mut b, at + TRIGGER_AT, c.trigger);
        put_f32(&mut b, at + SQUEEZE_AT, c.squeeze);
        put_f32(&mut b, at + THUMBSTICK_AT, c.thumbstick[0]);
        put_f32(&mut b, at + THUMBSTICK_AT + 4, c.thumbstick[1]);
        let bools = at + BOOLS_AT;
        b[bools + ACTIVE] = 1;
        b[bools + B_CLICK] = u8::from(c.b_click);
        b[bools + TRIGGER_CLICK] = u8::from(c.trigger > 0.5);
        b[bools + THUMBSTICK_CLICK] = u8::from(c.thumbstick_click);
    }
    debug_assert_eq!(CONTROLLERS_AT[1] + CONTROLLER_SIZE, PACKET_SIZE);
    b
}

/// A pose: orientation (x, y, z, w) and position.
#[derive(Clone, Copy, Debug)]
pub struct RemotePose {
    /// Unit quaternion x, y, z, w.
    pub orientation: [f32; 4],
    /// Metres.
    pub position: [f32; 3],
}

/// The head (centre) pose, and per eye the FOV
/// (left, right, up, down in radians) and the pose relative to the head.
#[derive(Clone, Copy, Debug)]
pub struct RemoteHead {
    /// Head pose in the tracking space.
    pub center: RemotePose,
    /// Per eye: FOV angles and pose in head space.
    pub views: [([f32; 4], RemotePose); 2],
}

fn put_pose(buf: &mut [u8], at: usize, p: &RemotePose) {
    for (i, v) in p.orientation.iter().chain(p.position.iter()).enumerate() {
        buf[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
    }
}

/// Encodes `head` as one packet (controllers inactive, identity poses).
pub fn encode(head: &RemoteHead) -> [u8; PACKET_SIZE] {
    let mut b = [0u8; PACKET_SIZE];
    b[..8].copy_from_slice(b"mndrmt3\0");
    for (i, (fov, pose)) in head.views.iter().enumerate() {
        let at = HEAD_AT + i * VIEW_SIZE;
        for (k, v) in fov.iter().enumerate() {
            b[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
        put_pose(&mut b, at + 16, pose);
    }
    put_pose(&mut b, CENTER_AT, &head.center);
    b[PER_VIEW_VALID_AT] = 1;
    let identity = RemotePose {
        orientation: [0.0, 0.0, 0.0, 1.0],
        position: [0.0; 3],
    };
    for at in CONTROLLERS_AT {
        put_pose(&mut b, at, &identity);
    }
    b
}

/// Connects to the remote driver on loopback, retrying until `timeout`.
pub fn connect(timeout: Duration) -> std::io::Result<TcpStream> {
    let start = Instant::now();
    loop {
        match TcpStream::connect(("127.0.0.1", PORT)) {
            Ok(s) => {
                s.set_read_timeout(Some(Duration::from_millis(200)))?;
                return Ok(s);
            }
            Err(e) if start.elapsed() > timeout => return Err(e),
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

/// Sends `head`, draining whatever the driver sent us first.
pub fn send(stream: &mut TcpStream, head: &RemoteHead) -> std::io::Result<()> {
    send_packet(stream, &encode(head))
}

/// Sends one encoded packet, draining whatever the driver sent us first.
pub fn send_packet(stream: &mut TcpStream, packet: &[u8; PACKET_SIZE]) -> std::io::Result<()> {
    let mut sink = [0u8; PACKET_SIZE];
    while let Ok(n) = stream.read(&mut sink) {
        if n == 0 {
            break;
        }
    }
    stream.write_all(packet)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packet_layout_matches_r_remote_data() {
        let head = RemoteHead {
            center: RemotePose {
                orientation: [0.0, 0.0, 0.0, 1.0],
                position: [1.0, 2.0, 3.0],
            },
            views: [
                (
                    [-0.9, 0.6, 0.7, -0.8],
                    RemotePose {
                        orientation: [0.0, 0.0, 0.0, 1.0],
                        position: [-0.032, 0.0, 0.0],
                    },
                ),
                (
                    [-0.6, 0.9, 0.75, -0.85],
                    RemotePose {
                        orientation: [0.0, 0.0, 0.0, 1.0],
                        position: [0.032, 0.0, 0.0],
                    },
                ),
            ],
        };
        let b = encode(&head);
        let f = |at: usize| f32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
        assert_eq!(&b[..8], b"mndrmt3\0");
        assert_eq!(f(8), -0.9, "view 0 angle_left");
        assert_eq!(f(8 + 48 + 4), 0.9, "view 1 angle_right");
        assert_eq!(f(8 + 16 + 16), -0.032, "view 0 position x");
        assert_eq!(f(104 + 16), 1.0, "centre position x");
        assert_eq!(b[132], 1, "per_view_data_valid");
        assert_eq!(f(136 + 12), 1.0, "left controller orientation w");
        assert_eq!(f(256 + 12), 1.0, "right controller orientation w");
    }

    #[test]
    fn controller_fields_sit_at_r_remote_controller_data_offsets() {
        let head = RemoteHead {
            center: RemotePose {
                orientation: [0.0, 0.0, 0.0, 1.0],
                position: [0.0, 1.6, 0.0],
            },
            views: [(
                [-0.7, 0.7, 0.7, -0.7],
                RemotePose {
                    orientation: [0.0, 0.0, 0.0, 1.0],
                    position: [0.0; 3],
                },
            ); 2],
        };
        let right = RemoteController {
            trigger: 0.75,
            squeeze: 0.25,
            thumbstick: [0.5, -1.0],
            thumbstick_click: true,
            b_click: true,
            ..RemoteController::at(RemotePose {
                orientation: [0.0, 0.0, 0.0, 1.0],
                position: [0.3, 1.1, -0.4],
            })
        };
        let b = encode_with(&head, [None, Some(right)]);
        let f = |at: usize| f32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
        assert_eq!(f(256 + 16), 0.3, "right position x");
        assert_eq!(f(256 + 72), 0.75, "trigger_value");
        assert_eq!(f(256 + 76), 0.25, "squeeze_value");
        assert_eq!((f(256 + 84), f(256 + 88)), (0.5, -1.0), "thumbstick");
        assert_eq!(b[256 + 105], 1, "active");
        assert_eq!(b[256 + 110], 1, "b_click");
        assert_eq!(b[256 + 112], 1, "trigger_click");
        assert_eq!(b[256 + 114], 1, "thumbstick_click");
        assert_eq!(b[136 + 105], 0, "left inactive");
        assert_eq!(b.len(), 376);
    }
}
