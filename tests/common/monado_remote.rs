//! Client for Monado's remote driver (`P_OVERRIDE_ACTIVE_CONFIG=remote`):
//! one TCP connection on loopback port 4242; each packet is the whole
//! `struct r_remote_data` of Monado's `drivers/remote/r_interface.h`
//! (header "mndrmt3\0"), 376 bytes, little endian, and the last packet
//! stays in effect. Layout (byte offsets):
//!
//! - 0: u64 header
//! - 8: head: 2 views × 48 bytes {fov: left, right, up, down (f32);
//!   pose: orientation x, y, z, w, position x, y, z (f32); u32 pad}
//! - 104: head centre pose (28 bytes); 132: bool per_view_data_valid + 3 pad
//! - 136: left controller (120 bytes); 256: right controller (120 bytes);
//!   each starts with its pose (orientation must be a unit quaternion).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// Size of `struct r_remote_data`.
pub const PACKET_SIZE: usize = 376;
const HEAD_AT: usize = 8;
const VIEW_SIZE: usize = 48;
const CENTER_AT: usize = HEAD_AT + 2 * VIEW_SIZE;
const PER_VIEW_VALID_AT: usize = CENTER_AT + 28;
const CONTROLLERS_AT: [usize; 2] = [136, 256];

/// A pose: orientation (x, y, z, w) and position.
#[derive(Clone, Copy, Debug)]
pub struct RemotePose {
    /// Unit quaternion x, y, z, w.
    pub orientation: [f32; 4],
    /// Metres.
    pub position: [f32; 3],
}

/// What the test sets: the head (centre) pose, and per eye the FOV
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
        match TcpStream::connect(("127.0.0.1", 4242)) {
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
    let mut sink = [0u8; PACKET_SIZE];
    while let Ok(n) = stream.read(&mut sink) {
        if n == 0 {
            break;
        }
    }
    stream.write_all(&encode(head))
}

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
