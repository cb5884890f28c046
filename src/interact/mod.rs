//! What the user does with the controllers, as pure logic over poses and
//! scene queries (no OpenXR or Vulkan types): locomotion (teleport arcs,
//! smooth move, fly, snap turn about the head, world grab with two-hand
//! scale/rotate, recentring) in [`locomotion`], exact ray casts against the
//! scene in [`raycast`], measuring in [`measure`] and section planes in
//! [`section`]. [`Interaction`] turns one frame of controller input into a
//! new tracking origin and a list of [`Event`]s with the default mapping:
//!
//! | input | effect |
//! |---|---|
//! | left stick | smooth move (head- or hand-directed), fly follows the pitch |
//! | left stick click | fly mode on/off |
//! | right stick left/right | snap turn about the head |
//! | right stick forward, release | aim a teleport arc; release teleports |
//! | right stick click | recentre (back to the spawn), or the next viewpoint when there are several |
//! | trigger (either hand) | the current tool: select, measure or section plane |
//! | squeeze (one / both hands) | grab and drag the world / scale and turn it |
//! | menu | opens or closes the panel ([`panel`]); with the panel off (`run --panel off`), the next tool (select → measure → section → select) |
//! | trigger on the open panel | presses the panel button the ray points at |

pub mod locomotion;
pub mod measure;
pub mod overlay;
pub mod panel;
pub mod raycast;
pub mod scan;
pub mod section;

use crate::scene::Scene;
use crate::view::Pose;
use glam::DVec3;
use locomotion::{cast_teleport, one_hand_drag, smooth_move, ArcResult, Origin, TwoHandGrab};
use measure::Measure;
use panel::{Panel, PanelHit};
use raycast::{Hit, Ray, SceneQuery};
use section::SectionPlane;

/// Hands, in the order of [`FrameInput::hands`].
pub const HANDS: [&str; 2] = ["left", "right"];

/// Longest pointing ray, metres (world, at scale 1).
pub const POINT_RANGE: f64 = 2000.0;

/// One hand's input in tracking space for one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HandInput {
    /// Aim pose (the pointing ray runs along its −Z), when tracked.
    pub aim: Option<Pose>,
    /// Grip pose (where the controller is held), when tracked.
    pub grip: Option<Pose>,
    /// Trigger, 0..1.
    pub select: f32,
    /// Squeeze, 0..1.
    pub squeeze: f32,
    /// Thumbstick (or trackpad): x right, y forward, each −1..1.
    pub stick: [f32; 2],
    /// Thumbstick (or trackpad) click.
    pub stick_click: bool,
    /// Menu button.
    pub menu: bool,
}

/// One frame's input: the head and both hands in tracking space.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameInput {
    /// Seconds since the previous frame (display time).
    pub dt: f64,
    /// Head pose, tracking space.
    pub head: Pose,
    /// Left and right hands.
    pub hands: [HandInput; 2],
}

/// Which way smooth move goes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MoveDirection {
    /// Where the head looks.
    #[default]
    Head,
    /// Where the moving hand points.
    Hand,
}

/// Locomotion settings.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Settings {
    /// Smooth move speed, m/s (world, at scale 1).
    pub move_speed: f64,
    /// Snap turn angle, degrees.
    pub snap_turn_deg: f64,
    /// Smooth turn rate, degrees/s, instead of snap turns (None: snap).
    pub smooth_turn_deg_s: Option<f64>,
    /// Smooth move direction.
    pub move_direction: MoveDirection,
    /// Teleport arc launch speed, m/s.
    pub arc_speed: f64,
    /// The menu button opens the in-headset panel (false: it cycles the
    /// tools, as without a panel).
    pub panel: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            move_speed: 2.0,
            snap_turn_deg: 30.0,
            smooth_turn_deg_s: None,
            move_direction: MoveDirection::Head,
            arc_speed: locomotion::ARC_SPEED,
            panel: false,
        }
    }
}

impl Settings {
    /// Rejects values the loop cannot use, naming the setting.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.move_speed.is_finite() && self.move_speed >= 0.0 && self.move_speed <= 1000.0) {
            return Err(format!(
                "move speed {} m/s must be within 0..=1000",
                self.move_speed
            ));
        }
        if !(self.snap_turn_deg.is_finite()
            && self.snap_turn_deg > 0.0
            && self.snap_turn_deg <= 180.0)
        {
            return Err(format!(
                "snap turn {}° must be within (0, 180]",
                self.snap_turn_deg
            ));
        }
        if let Some(r) = self.smooth_turn_deg_s {
            if !(r.is_finite() && r > 0.0 && r <= 720.0) {
                return Err(format!("smooth turn {r}°/s must be within (0, 720]"));
            }
        }
        if !(self.arc_speed.is_finite() && self.arc_speed > 0.0 && self.arc_speed <= 100.0) {
            return Err(format!(
                "arc speed {} m/s must be within (0, 100]",
                self.arc_speed
            ));
        }
        Ok(())
    }
}

/// What the trigger does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Tool {
    /// Point at an instance and name it.
    #[default]
    Select,
    /// Place two points and measure between them.
    Measure,
    /// Place a section plane.
    Section,
}

impl Tool {
    /// Every tool, in the menu button's order.
    pub const ALL: [Tool; 3] = [Tool::Select, Tool::Measure, Tool::Section];

    /// Its name in the frame records and on the panel.
    pub fn name(self) -> &'static str {
        match self {
            Tool::Select => "select",
            Tool::Measure => "measure",
            Tool::Section => "section",
        }
    }

    fn next(self) -> Tool {
        match self {
            Tool::Select => Tool::Measure,
            Tool::Measure => Tool::Section,
            Tool::Section => Tool::Select,
        }
    }
}

/// What an instance the user pointed at is.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Picked {
    /// Instance index.
    pub instance: u32,
    /// The source node's name, when the scene keeps node names.
    pub node: Option<String>,
    /// The node's path from the scene root, names joined by `/`.
    pub path: Option<String>,
    /// Mesh name.
    pub mesh: String,
    /// Material name of the primitive hit.
    pub material: String,
    /// The node's glTF `extras`.
    pub extras: Option<serde_json::Value>,
    /// World-space hit point.
    pub point: [f64; 3],
    /// Distance from the hand, metres.
    pub distance_m: f64,
}

/// Names the instance `hit` lies on.
pub fn describe(scene: &Scene, hit: &Hit, from: DVec3) -> Picked {
    let inst = scene.instances.get(hit.instance as usize);
    let mesh = inst
        .and_then(|i| scene.meshes.get(i.mesh as usize))
        .map_or_else(String::new, |m| m.name.clone());
    let material = scene
        .primitives
        .get(hit.primitive as usize)
        .and_then(|p| scene.materials.get(p.material as usize))
        .map_or_else(String::new, |m| m.name.clone());
    let node = scene.node_of(hit.instance as usize);
    let info = node.and_then(|n| scene.node_info.get(n as usize));
    Picked {
        instance: hit.instance,
        node: info.and_then(|i| i.name.clone()),
        path: node.map(|n| scene.node_path(n)),
        mesh,
        material,
        extras: info
            .and_then(|i| i.extras.as_deref())
            .and_then(|t| serde_json::from_str(t).ok()),
        point: hit.point.to_array(),
        distance_m: hit.point.distance(from),
    }
}

/// Something the user did, as logged in the frame records (`events`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Event {
    /// The head moved to a teleport target.
    Teleport {
        /// Head world position before.
        from: [f64; 3],
        /// The target on the ground.
        to: [f64; 3],
    },
    /// The view turned about the head.
    Turn {
        /// Degrees, positive to the left (counter-clockwise from above).
        degrees: f64,
    },
    /// A grab started or ended.
    Grab {
        /// Hands now holding the world (0: released).
        hands: u8,
        /// Tracking-to-world scale when it changed.
        scale: f64,
    },
    /// The trigger named an instance.
    Select {
        /// Which hand.
        hand: &'static str,
        /// What was hit.
        #[serde(flatten)]
        picked: Picked,
    },
    /// A measurement was completed.
    Measure {
        /// Distance, metres, rounded to the millimetre.
        distance_m: f64,
        /// The label shown, e.g. "2.357 m".
        label: String,
    },
    /// A measurement point was placed.
    MeasurePoint {
        /// World position.
        point: [f64; 3],
    },
    /// The section plane was placed, moved to a new place, or removed.
    Section {
        /// The plane (normal x, y, z, offset), None when removed.
        plane: Option<[f64; 4]>,
    },
    /// Fly mode switched.
    Fly {
        /// On or off.
        on: bool,
    },
    /// The origin went to a viewpoint: back to the current one with a
    /// single viewpoint (recentre), else to the next.
    Recenter {
        /// Index of the viewpoint now in use (0: the spawn).
        viewpoint: usize,
    },
    /// The menu button: the next tool (without the panel).
    Menu {
        /// The tool now on the trigger.
        tool: Tool,
    },
    /// The menu button opened or closed the panel.
    Panel {
        /// Open now.
        open: bool,
    },
    /// A panel button was pressed.
    PanelButton {
        /// The button's name (e.g. `tool:measure`, `toggle:stencil-mask`,
        /// `close`).
        button: String,
    },
    /// A panel button chose the trigger's tool.
    Tool {
        /// The tool now on the trigger.
        tool: Tool,
    },
}

/// A button from an analogue value with hysteresis: on above 0.55, off
/// below 0.35 (so a half-pressed trigger does not chatter).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Latch {
    on: bool,
}

impl Latch {
    /// Updates with `v`; true on the press edge.
    fn press(&mut self, v: f32) -> bool {
        let was = self.on;
        if v > 0.55 {
            self.on = true;
        } else if v < 0.35 {
            self.on = false;
        }
        self.on && !was
    }
}

/// The grab in progress.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Grab {
    One { hand: usize, world: DVec3 },
    Two(TwoHandGrab),
}

/// What one frame of [`Interaction::update`] produced besides the origin.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Update {
    /// Events of the frame.
    pub events: Vec<Event>,
    /// Per hand: a short haptic tick is due (the ray moved onto a new instance).
    pub haptic: [bool; 2],
    /// The teleport arc being aimed, if any.
    pub arc: Option<ArcResult>,
    /// Per hand: what its ray points at (world).
    pub hover: [Option<Hit>; 2],
    /// Per hand: where its ray meets the open panel (then it points at
    /// nothing in the scene).
    pub panel_pointer: [Option<PanelHit>; 2],
    /// A trigger press on the open panel: the hand and where it pointed.
    pub panel_press: Option<(usize, [f64; 2])>,
}

/// The interaction state carried from frame to frame.
#[derive(Clone, Debug)]
pub struct Interaction {
    /// Where tracking space sits in the world now.
    pub origin: Origin,
    /// Where it started (recentre goes back here), then further
    /// viewpoints the right stick click cycles through.
    pub viewpoints: Vec<Origin>,
    /// The viewpoint in use.
    pub viewpoint: usize,
    /// Settings.
    pub settings: Settings,
    /// Fly mode.
    pub fly: bool,
    /// The trigger's tool.
    pub tool: Tool,
    /// The measuring tool.
    pub measure: Measure,
    /// The section plane, when placed.
    pub section: Option<SectionPlane>,
    /// The in-headset panel, while open.
    pub panel: Option<Panel>,
    triggers: [Latch; 2],
    squeezes: [bool; 2],
    clicks: [bool; 2],
    menu: bool,
    snap_armed: bool,
    aiming: bool,
    grab: Option<Grab>,
    hovered: [Option<u32>; 2],
}

impl Interaction {
    /// Starts at `spawn`.
    pub fn new(spawn: Origin, settings: Settings) -> Interaction {
        Interaction {
            origin: spawn,
            viewpoints: vec![spawn],
            viewpoint: 0,
            settings,
            fly: false,
            tool: Tool::Select,
            measure: Measure::default(),
            section: None,
            panel: None,
            triggers: [Latch::default(); 2],
            squeezes: [false; 2],
            clicks: [false; 2],
            menu: false,
            snap_armed: true,
            aiming: false,
            grab: None,
            hovered: [None; 2],
        }
    }

    /// The world ray of a hand's aim pose.
    fn ray(&self, aim: &Pose) -> Ray {
        let w = self.origin.pose(aim);
        Ray {
            origin: w.position,
            direction: w.forward(),
            max_t: POINT_RANGE * self.origin.scale,
        }
    }

    /// Applies one frame of input: moves the origin and reports events.
    /// Non-finite input (a runtime sending garbage) is ignored for the
    /// frame, with the hand treated as idle.
    pub fn update(&mut self, input: &FrameInput, q: &SceneQuery) -> Update {
        let mut out = Update::default();
        let dt = if input.dt.is_finite() {
            input.dt.clamp(0.0, 0.1)
        } else {
            0.0
        };
        let head_ok = input.head.validate().is_ok();
        let hands = input.hands.map(sanitized);
        // Grab first: while the world is held, sticks do not move it.
        self.update_grab(&hands, &mut out);
        let grabbing = self.grab.is_some();
        self.left_stick(&hands[0], input, dt, grabbing || !head_ok, &mut out);
        self.right_stick(&hands[1], input, q, dt, grabbing || !head_ok, &mut out);
        self.update_menu(&hands, input, head_ok, &mut out);
        for (i, h) in hands.iter().enumerate() {
            self.point(i, h, q, &mut out);
        }
        out
    }

    /// Left stick: smooth move (unless `held`: grabbing or no head pose);
    /// its click: fly.
    fn left_stick(
        &mut self,
        left: &HandInput,
        input: &FrameInput,
        dt: f64,
        held: bool,
        out: &mut Update,
    ) {
        if self.clicks[0] != left.stick_click {
            self.clicks[0] = left.stick_click;
            if left.stick_click {
                self.fly = !self.fly;
                out.events.push(Event::Fly { on: self.fly });
            }
        }
        let stick = [left.stick[0] as f64, left.stick[1] as f64];
        let dead = (stick[0] * stick[0] + stick[1] * stick[1]).sqrt() < 0.15;
        if held || dead {
            return;
        }
        let facing = match (self.settings.move_direction, left.aim) {
            (MoveDirection::Hand, Some(aim)) => self.origin.pose(&aim).forward(),
            _ => self.origin.pose(&input.head).forward(),
        };
        let speed = self.settings.move_speed * self.origin.scale;
        self.origin.position += smooth_move(facing, stick, speed, dt, self.fly);
    }

    /// Right stick: snap (or smooth) turn and teleport aim (unless `held`:
    /// grabbing or no head pose); its click: the next viewpoint.
    fn right_stick(
        &mut self,
        right: &HandInput,
        input: &FrameInput,
        q: &SceneQuery,
        dt: f64,
        held: bool,
        out: &mut Update,
    ) {
        if self.clicks[1] != right.stick_click {
            self.clicks[1] = right.stick_click;
            if right.stick_click {
                let n = self.viewpoints.len().max(1);
                self.viewpoint = if n > 1 { (self.viewpoint + 1) % n } else { 0 };
                if let Some(v) = self.viewpoints.get(self.viewpoint) {
                    self.origin = *v;
                }
                out.events.push(Event::Recenter {
                    viewpoint: self.viewpoint,
                });
            }
        }
        if held {
            self.aiming = false;
            return;
        }
        let [sx, sy] = right.stick.map(f64::from);
        self.turn(sx, sy, input, dt, out);
        if sy > 0.7 && sy >= sx.abs() {
            self.aiming = true;
        }
        if self.aiming {
            self.aim_teleport(right, (sx * sx + sy * sy).sqrt(), input, q, out);
        }
    }

    /// A sideways right stick turns about the head: smoothly at the set
    /// rate, or one snap per push (re-armed when the stick returns).
    fn turn(&mut self, sx: f64, sy: f64, input: &FrameInput, dt: f64, out: &mut Update) {
        let pivot = self.origin.pose(&input.head).position;
        if sx.abs() > 0.7 && sx.abs() > sy.abs() && !self.aiming {
            match self.settings.smooth_turn_deg_s {
                Some(rate) => {
                    let a = -sx.signum() * (sx.abs() - 0.7) / 0.3 * rate.to_radians() * dt;
                    self.origin = self.origin.turned_about(pivot, a);
                }
                None if self.snap_armed => {
                    // Stick right turns right: negative yaw.
                    let deg = -sx.signum() * self.settings.snap_turn_deg;
                    self.origin = self.origin.turned_about(pivot, deg.to_radians());
                    out.events.push(Event::Turn { degrees: deg });
                    self.snap_armed = false;
                }
                None => {}
            }
        } else if sx.abs() < 0.35 {
            self.snap_armed = true;
        }
    }

    /// While aiming: the teleport arc from the right hand; releasing the
    /// stick (`mag` below 0.35) teleports to the arc's target, if any.
    fn aim_teleport(
        &mut self,
        right: &HandInput,
        mag: f64,
        input: &FrameInput,
        q: &SceneQuery,
        out: &mut Update,
    ) {
        let arc = right.aim.map(|aim| {
            let w = self.origin.pose(&aim);
            // A projectile's range goes as v²/g: √scale on the launch
            // speed makes the reach scale with the user.
            let speed = self.settings.arc_speed * self.origin.scale.sqrt();
            cast_teleport(q, w.position, w.forward(), speed)
        });
        if mag >= 0.35 {
            out.arc = arc;
            return;
        }
        self.aiming = false;
        if let Some(target) = arc.as_ref().and_then(|a| a.target) {
            let from = self.origin.pose(&input.head).position;
            self.origin = self.origin.teleported(input.head.position, target);
            out.events.push(Event::Teleport {
                from: from.to_array(),
                to: target.to_array(),
            });
        }
    }

    /// Menu (either hand): the panel, or the next tool without one.
    fn update_menu(
        &mut self,
        hands: &[HandInput; 2],
        input: &FrameInput,
        head_ok: bool,
        out: &mut Update,
    ) {
        let menu = hands[0].menu || hands[1].menu;
        if menu && !self.menu {
            if !self.settings.panel {
                self.tool = self.tool.next();
                out.events.push(Event::Menu { tool: self.tool });
            } else if self.panel.take().is_some() {
                out.events.push(Event::Panel { open: false });
            } else if head_ok {
                self.panel = Some(Panel::facing(&input.head));
                out.events.push(Event::Panel { open: true });
            }
        }
        self.menu = menu;
    }

    /// Hand `i`'s ray and trigger: the open panel is in front of the scene
    /// (a ray on it points at the panel only, and its trigger presses the
    /// panel); otherwise the ray hovers the scene and the trigger uses the
    /// tool on what it hits.
    fn point(&mut self, i: usize, h: &HandInput, q: &SceneQuery, out: &mut Update) {
        let pressed = self.triggers[i].press(h.select);
        let Some(aim) = h.aim else {
            self.hovered[i] = None;
            return;
        };
        if let Some(on) = self.panel.as_ref().and_then(|p| p.hit(&aim)) {
            self.hovered[i] = None;
            out.panel_pointer[i] = Some(on);
            if pressed {
                out.panel_press = Some((i, on.uv));
            }
            return;
        }
        let ray = self.ray(&aim);
        let hit = q.cast(&ray);
        let now = hit.map(|h| h.instance);
        out.haptic[i] = now.is_some() && now != self.hovered[i];
        self.hovered[i] = now;
        out.hover[i] = hit;
        if pressed {
            self.use_tool(i, &aim, hit, ray.origin, q, out);
        }
    }

    /// The trigger of hand `i` pressed with the current tool on `hit`.
    fn use_tool(
        &mut self,
        i: usize,
        aim: &Pose,
        hit: Option<Hit>,
        from: DVec3,
        q: &SceneQuery,
        out: &mut Update,
    ) {
        match (self.tool, hit) {
            (Tool::Select, Some(hit)) => out.events.push(Event::Select {
                hand: HANDS[i],
                picked: describe(q.scene(), &hit, from),
            }),
            (Tool::Measure, Some(hit)) => match self.measure.press(hit.point) {
                Some(d) => out.events.push(Event::Measure {
                    distance_m: d,
                    label: measure::label(d),
                }),
                None => out.events.push(Event::MeasurePoint {
                    point: hit.point.to_array(),
                }),
            },
            (Tool::Section, _) => {
                self.section = match self.section {
                    Some(_) => None,
                    None => SectionPlane::from_hand(&self.origin.pose(aim)),
                };
                out.events.push(Event::Section {
                    plane: self
                        .section
                        .map(|p| [p.normal.x, p.normal.y, p.normal.z, p.d]),
                });
            }
            _ => {}
        }
    }

    /// Puts `tool` on the trigger (a panel button), as an event.
    pub fn set_tool(&mut self, tool: Tool) -> Event {
        self.tool = tool;
        Event::Tool { tool }
    }

    /// Closes the panel (its close button), as an event when it was open.
    pub fn close_panel(&mut self) -> Option<Event> {
        self.panel.take().map(|_| Event::Panel { open: false })
    }

    fn update_grab(&mut self, hands: &[HandInput; 2], out: &mut Update) {
        let mut held = [false; 2];
        for (i, h) in hands.iter().enumerate() {
            // Hysteresis on the squeeze: held above 0.55, let go below 0.35.
            held[i] = h.grip.is_some()
                && if self.squeezes[i] {
                    h.squeeze > 0.35
                } else {
                    h.squeeze > 0.55
                };
        }
        let changed = held != self.squeezes;
        self.squeezes = held;
        let grip = |i: usize| hands[i].grip.map(|p| p.position).unwrap_or_default();
        if changed {
            self.grab = match held {
                [true, true] => Some(Grab::Two(TwoHandGrab::start(
                    self.origin,
                    [grip(0), grip(1)],
                ))),
                [true, false] => Some(Grab::One {
                    hand: 0,
                    world: self.origin.point(grip(0)),
                }),
                [false, true] => Some(Grab::One {
                    hand: 1,
                    world: self.origin.point(grip(1)),
                }),
                [false, false] => None,
            };
            out.events.push(Event::Grab {
                hands: held.iter().filter(|h| **h).count() as u8,
                scale: self.origin.scale,
            });
            return;
        }
        match self.grab {
            Some(Grab::One { hand, world }) => {
                self.origin = one_hand_drag(&self.origin, world, grip(hand));
            }
            Some(Grab::Two(g)) => {
                self.origin = g.update([grip(0), grip(1)]);
            }
            None => {}
        }
    }
}

/// A hand's input with non-finite buttons or sticks treated as idle,
/// invalid poses dropped and the stick within -1..1.
fn sanitized(mut h: HandInput) -> HandInput {
    let finite =
        h.select.is_finite() && h.squeeze.is_finite() && h.stick.iter().all(|v| v.is_finite());
    if !finite {
        h = HandInput::default();
    }
    h.aim = h.aim.filter(|p| p.validate().is_ok());
    h.grip = h.grip.filter(|p| p.validate().is_ok());
    h.stick = h.stick.map(|v| v.clamp(-1.0, 1.0));
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{shapes, Instance, Material, Mesh};
    use glam::{DAffine3, DQuat};

    fn floor_scene() -> Scene {
        let mut s = Scene::default();
        s.materials.push(Material {
            name: "concrete".into(),
            ..Material::default()
        });
        s.primitives.push(shapes::cuboid([50.0, 0.05, 50.0], 0));
        s.meshes.push(Mesh {
            name: "floor".into(),
            primitives: vec![0],
        });
        s.instances.push(Instance {
            mesh: 0,
            transform: DAffine3::from_translation(DVec3::new(0.0, -0.05, 0.0)),
        });
        s
    }

    fn head() -> Pose {
        Pose::from_euler_deg(DVec3::new(0.0, 1.6, 0.0), 0.0, 0.0, 0.0)
    }

    fn hand(stick: [f32; 2], select: f32) -> HandInput {
        HandInput {
            aim: Some(Pose::from_euler_deg(
                DVec3::new(0.2, 1.2, -0.3),
                0.0,
                -45.0,
                0.0,
            )),
            grip: Some(Pose::from_euler_deg(
                DVec3::new(0.2, 1.2, -0.3),
                0.0,
                0.0,
                0.0,
            )),
            select,
            stick,
            ..HandInput::default()
        }
    }

    fn frame(left: HandInput, right: HandInput) -> FrameInput {
        FrameInput {
            dt: 0.05,
            head: head(),
            hands: [left, right],
        }
    }

    #[test]
    fn default_mapping_moves_turns_teleports_and_selects() {
        let s = floor_scene();
        let q = SceneQuery::new(&s);
        let mut it = Interaction::new(Origin::default(), Settings::default());
        let idle = hand([0.0, 0.0], 0.0);
        // Left stick forward for 20 frames of 50 ms: 2 m/s × 1 s along −Z.
        for _ in 0..20 {
            it.update(&frame(hand([0.0, 1.0], 0.0), idle), &q);
        }
        assert!((it.origin.position - DVec3::new(0.0, 0.0, -2.0)).length() < 1e-9);
        // Right stick right: one 30° snap turn to the right, however long held.
        let mut turns = 0;
        for _ in 0..5 {
            let u = it.update(&frame(idle, hand([1.0, 0.0], 0.0)), &q);
            turns += u
                .events
                .iter()
                .filter(|e| matches!(e, Event::Turn { .. }))
                .count();
        }
        assert_eq!(turns, 1);
        assert!((it.origin.yaw + 30f64.to_radians()).abs() < 1e-12);
        let head_before = it.origin.point(head().position);
        it.update(&frame(idle, idle), &q);
        // Right stick forward aims; release teleports to the arc's target.
        let u = it.update(&frame(idle, hand([0.0, 1.0], 0.0)), &q);
        let target = u.arc.expect("aiming").target.expect("lands on the floor");
        let u = it.update(&frame(idle, idle), &q);
        assert!(
            matches!(u.events[..], [Event::Teleport { .. }]),
            "{:?}",
            u.events
        );
        let h = it.origin.point(head().position);
        assert!((h.x - target.x).abs() < 1e-9 && (h.z - target.z).abs() < 1e-9);
        assert!((h.y - 1.6).abs() < 1e-9 && h.distance(head_before) > 1.0);
        // Trigger names the floor.
        let u = it.update(&frame(idle, hand([0.0, 0.0], 1.0)), &q);
        match &u.events[..] {
            [Event::Select { hand, picked }] => {
                assert_eq!(*hand, "right");
                assert_eq!(
                    (picked.mesh.as_str(), picked.material.as_str()),
                    ("floor", "concrete")
                );
            }
            other => panic!("{other:?}"),
        }
        // Menu twice: measure, then section.
        let menu = HandInput { menu: true, ..idle };
        it.update(&frame(menu, idle), &q);
        assert_eq!(it.tool, Tool::Measure);
        it.update(&frame(idle, idle), &q);
        let mut ev = Vec::new();
        for x in [0.0, 0.5] {
            let mut h = hand([0.0, 0.0], 1.0);
            h.aim = Some(Pose::from_euler_deg(
                DVec3::new(x, 1.0, 0.0),
                0.0,
                -90.0,
                0.0,
            ));
            ev.extend(it.update(&frame(idle, h), &q).events);
            ev.extend(it.update(&frame(idle, idle), &q).events);
        }
        let d = ev.iter().find_map(|e| match e {
            Event::Measure { distance_m, .. } => Some(*distance_m),
            _ => None,
        });
        assert_eq!(d, Some(0.5), "{ev:?}");
    }

    #[test]
    fn the_right_stick_click_recentres_or_cycles_viewpoints() {
        let s = floor_scene();
        let q = SceneQuery::new(&s);
        let spawn = Origin::default();
        let mut it = Interaction::new(spawn, Settings::default());
        let idle = hand([0.0, 0.0], 0.0);
        let click = HandInput {
            stick_click: true,
            ..idle
        };
        it.update(&frame(hand([0.0, 1.0], 0.0), idle), &q);
        assert_ne!(it.origin, spawn);
        it.update(&frame(idle, click), &q);
        assert_eq!(it.origin, spawn, "recentred");
        let other = Origin {
            position: DVec3::new(40.0, 2.0, -7.0),
            yaw: 1.0,
            scale: 1.0,
        };
        it.viewpoints.push(other);
        it.update(&frame(idle, idle), &q);
        let u = it.update(&frame(idle, click), &q);
        assert_eq!(u.events, [Event::Recenter { viewpoint: 1 }]);
        assert_eq!(it.origin, other);
        it.update(&frame(idle, idle), &q);
        it.update(&frame(idle, click), &q);
        assert_eq!((it.viewpoint, it.origin), (0, spawn), "wraps around");
    }

    #[test]
    fn squeezing_drags_and_two_hands_scale_about_the_hands() {
        let s = floor_scene();
        let q = SceneQuery::new(&s);
        let mut it = Interaction::new(Origin::default(), Settings::default());
        let grip = |x: f64, squeeze: f32| HandInput {
            grip: Some(Pose::from_euler_deg(DVec3::new(x, 1.0, 0.0), 0.0, 0.0, 0.0)),
            squeeze,
            ..HandInput::default()
        };
        it.update(&frame(grip(-0.2, 1.0), grip(0.2, 1.0)), &q);
        // Hands twice as far apart: the user halves (the world doubles).
        it.update(&frame(grip(-0.4, 1.0), grip(0.4, 1.0)), &q);
        assert!((it.origin.scale - 0.5).abs() < 1e-12);
        let u = it.update(&frame(grip(-0.4, 0.0), grip(0.4, 0.0)), &q);
        assert!(matches!(u.events[..], [Event::Grab { hands: 0, .. }]));
        // Garbage from the runtime is ignored, not a panic.
        let mut bad = grip(0.0, f32::NAN);
        bad.aim = Some(Pose {
            position: DVec3::NAN,
            orientation: DQuat::IDENTITY,
        });
        let before = it.origin;
        it.update(&frame(bad, bad), &q);
        assert_eq!(it.origin, before);
    }
    #[test]
    fn the_menu_opens_the_panel_and_its_trigger_presses_it() {
        let s = floor_scene();
        let q = SceneQuery::new(&s);
        let settings = Settings {
            panel: true,
            ..Settings::default()
        };
        let mut it = Interaction::new(Origin::default(), settings);
        let idle = hand([0.0, 0.0], 0.0);
        let menu = HandInput { menu: true, ..idle };
        let u = it.update(&frame(idle, menu), &q);
        assert_eq!(u.events, [Event::Panel { open: true }]);
        assert_eq!(it.tool, Tool::Select, "the menu no longer cycles tools");
        let p = it.panel.expect("open");
        assert!(p.pose.position.distance(DVec3::new(0.0, 1.45, -0.6)) < 1e-12);
        // Aim the right hand at a point of the panel: its ray stops there
        // and the trigger presses the panel, not the floor behind it.
        let target = p.point([0.25, 0.75]);
        let from = DVec3::new(0.2, 1.2, -0.3);
        let mut on = hand([0.0, 0.0], 0.0);
        on.aim = Some(Pose {
            position: from,
            orientation: DQuat::from_rotation_arc(DVec3::NEG_Z, (target - from).normalize()),
        });
        it.update(&frame(idle, menu), &q);
        let u = it.update(&frame(idle, on), &q);
        let pointer = u.panel_pointer[1].expect("on the panel");
        assert!((pointer.uv[0] - 0.25).abs() < 1e-9 && (pointer.uv[1] - 0.75).abs() < 1e-9);
        assert!(u.hover[1].is_none() && u.panel_press.is_none());
        let u = it.update(&frame(idle, HandInput { select: 1.0, ..on }), &q);
        let (hand_i, uv) = u.panel_press.expect("pressed");
        assert_eq!(hand_i, 1);
        assert!((uv[0] - 0.25).abs() < 1e-9);
        assert!(u.events.is_empty(), "{:?}", u.events);
        assert_eq!(
            it.set_tool(Tool::Measure),
            Event::Tool {
                tool: Tool::Measure
            }
        );
        // A ray beside the panel still reaches the scene: the floor.
        it.update(&frame(idle, idle), &q);
        let u = it.update(&frame(idle, hand([0.0, 0.0], 1.0)), &q);
        assert!(u.panel_pointer[1].is_none() && u.hover[1].is_some());
        assert!(
            matches!(u.events[..], [Event::MeasurePoint { .. }]),
            "{:?}",
            u.events
        );
        // Menu again closes it.
        it.update(&frame(idle, idle), &q);
        let u = it.update(&frame(menu, idle), &q);
        assert_eq!(u.events, [Event::Panel { open: false }]);
        assert!(it.panel.is_none() && it.close_panel().is_none());
    }
}
