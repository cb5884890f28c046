//! OpenXR actions: one action set with, per hand (subaction paths
//! `/user/hand/left` and `/user/hand/right`), aim and grip poses, select
//! (float), squeeze (float), thumbstick (vec2), thumbstick click, menu and
//! haptic output; suggested bindings for the common controller profiles
//! (a profile the runtime rejects is skipped with one log line); and the
//! per-frame read-out as [`crate::interact::HandInput`], in tracking space.

use super::{pose_of, XrCall};
use crate::error::Result;
use crate::interact::HandInput;
use openxr as xr;

/// What an input binds to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// Aim pose.
    Aim,
    /// Grip pose.
    Grip,
    /// Select (trigger), float.
    Select,
    /// Squeeze, float.
    Squeeze,
    /// Thumbstick or trackpad, vec2.
    Stick,
    /// Thumbstick or trackpad click.
    StickClick,
    /// Menu.
    Menu,
    /// Haptic output.
    Haptic,
}

/// One profile's suggested bindings: per slot, the input path under
/// `/user/hand/left` and under `/user/hand/right` (None: not bound on that
/// hand).
#[derive(Clone, Debug)]
pub struct ProfileBindings {
    /// `/interaction_profiles/...`.
    pub profile: &'static str,
    /// The instance extension the profile needs (None: core).
    pub extension: Option<&'static str>,
    /// Slot, left path, right path.
    pub bindings: Vec<(Slot, Option<&'static str>, Option<&'static str>)>,
}

/// Bindings shared by every controller profile: poses and haptics.
fn poses(haptic: bool) -> Vec<(Slot, Option<&'static str>, Option<&'static str>)> {
    let both = |p: &'static str| (Some(p), Some(p));
    let mut v = vec![
        (Slot::Aim, both("/input/aim/pose")),
        (Slot::Grip, both("/input/grip/pose")),
    ];
    if haptic {
        v.push((Slot::Haptic, both("/output/haptic")));
    }
    v.into_iter().map(|(s, (l, r))| (s, l, r)).collect()
}

/// The suggested bindings, one entry per interaction profile. Trackpad
/// controllers (Vive) drive the stick slots from the trackpad; the simple
/// controller has no stick or squeeze (select and menu only).
pub fn binding_table() -> Vec<ProfileBindings> {
    let same = |s: Slot, p: &'static str| (s, Some(p), Some(p));
    let stick_profile =
        |profile, extension, squeeze: &'static str, menu: [Option<&'static str>; 2]| {
            let mut b = poses(true);
            b.extend([
                same(Slot::Select, "/input/trigger/value"),
                same(Slot::Squeeze, squeeze),
                same(Slot::Stick, "/input/thumbstick"),
                same(Slot::StickClick, "/input/thumbstick/click"),
                (Slot::Menu, menu[0], menu[1]),
            ]);
            ProfileBindings {
                profile,
                extension,
                bindings: b,
            }
        };
    // Touch-style: the left hand has a menu button, the right hand's is
    // reserved for the system, so B opens the menu there.
    let touch_menu = [Some("/input/menu/click"), Some("/input/b/click")];
    let mut simple = poses(true);
    simple.extend([
        same(Slot::Select, "/input/select/click"),
        same(Slot::Menu, "/input/menu/click"),
    ]);
    let mut vive = poses(true);
    vive.extend([
        same(Slot::Select, "/input/trigger/value"),
        same(Slot::Squeeze, "/input/squeeze/click"),
        same(Slot::Stick, "/input/trackpad"),
        same(Slot::StickClick, "/input/trackpad/click"),
        same(Slot::Menu, "/input/menu/click"),
    ]);
    let mut hands = poses(false);
    hands.extend([
        same(Slot::Select, "/input/pinch_ext/value"),
        same(Slot::Squeeze, "/input/grasp_ext/value"),
    ]);
    vec![
        ProfileBindings {
            profile: "/interaction_profiles/khr/simple_controller",
            extension: None,
            bindings: simple,
        },
        stick_profile(
            "/interaction_profiles/oculus/touch_controller",
            None,
            "/input/squeeze/value",
            touch_menu,
        ),
        stick_profile(
            "/interaction_profiles/meta/touch_controller_plus",
            Some("XR_META_touch_controller_plus"),
            "/input/squeeze/value",
            touch_menu,
        ),
        stick_profile(
            "/interaction_profiles/meta/touch_plus_controller",
            None,
            "/input/squeeze/value",
            touch_menu,
        ),
        stick_profile(
            "/interaction_profiles/valve/index_controller",
            None,
            "/input/squeeze/value",
            [Some("/input/b/click"), Some("/input/b/click")],
        ),
        ProfileBindings {
            profile: "/interaction_profiles/htc/vive_controller",
            extension: None,
            bindings: vive,
        },
        stick_profile(
            "/interaction_profiles/microsoft/motion_controller",
            None,
            "/input/squeeze/click",
            [Some("/input/menu/click"), Some("/input/menu/click")],
        ),
        stick_profile(
            "/interaction_profiles/bytedance/pico4_controller",
            Some("XR_BD_controller_interaction"),
            "/input/squeeze/value",
            [Some("/input/menu/click"), Some("/input/b/click")],
        ),
        ProfileBindings {
            profile: "/interaction_profiles/ext/hand_interaction_ext",
            extension: Some("XR_EXT_hand_interaction"),
            bindings: hands,
        },
    ]
}

/// Turns on the instance extensions the binding table's profiles need,
/// where the runtime offers them.
pub fn enable_profile_extensions(available: &xr::ExtensionSet, exts: &mut xr::ExtensionSet) {
    exts.meta_touch_controller_plus = available.meta_touch_controller_plus;
    exts.bd_controller_interaction = available.bd_controller_interaction;
    exts.ext_hand_interaction = available.ext_hand_interaction;
}

fn extension_enabled(exts: &xr::ExtensionSet, name: &str) -> bool {
    match name {
        "XR_META_touch_controller_plus" => exts.meta_touch_controller_plus,
        "XR_BD_controller_interaction" => exts.bd_controller_interaction,
        "XR_EXT_hand_interaction" => exts.ext_hand_interaction,
        _ => false,
    }
}

/// The action set, its actions and the per-hand pose spaces. Fields drop
/// in declaration order: spaces before the actions and set they belong to.
pub struct Controls {
    aim_spaces: [xr::Space; 2],
    grip_spaces: [xr::Space; 2],
    select: xr::Action<f32>,
    squeeze: xr::Action<f32>,
    stick: xr::Action<xr::Vector2f>,
    stick_click: xr::Action<bool>,
    menu: xr::Action<bool>,
    haptic: xr::Action<xr::Haptic>,
    set: xr::ActionSet,
    hands: [xr::Path; 2],
    /// Profiles whose suggested bindings the runtime accepted.
    pub suggested: Vec<String>,
}

fn hand_paths(instance: &xr::Instance) -> Result<[xr::Path; 2]> {
    Ok([
        instance
            .string_to_path("/user/hand/left")
            .call("xrStringToPath")?,
        instance
            .string_to_path("/user/hand/right")
            .call("xrStringToPath")?,
    ])
}

impl Controls {
    /// Creates the action set and actions, suggests the bindings of every
    /// profile the runtime takes (skipping, with one log line each, those
    /// it rejects or whose extension is not enabled) and attaches the set
    /// to `session`. `api` is the instance's API version (profiles added
    /// to the core in 1.1 are skipped below it).
    pub fn new(
        instance: &xr::Instance,
        session: &xr::Session<xr::Vulkan>,
        exts: &xr::ExtensionSet,
        api: xr::Version,
    ) -> Result<Controls> {
        let hands = hand_paths(instance)?;
        let set = instance
            .create_action_set("vergence", "vergence", 0)
            .call("xrCreateActionSet")?;
        let aim = set
            .create_action::<xr::Posef>("aim_pose", "Aim pose", &hands)
            .call("xrCreateAction aim_pose")?;
        let grip = set
            .create_action::<xr::Posef>("grip_pose", "Grip pose", &hands)
            .call("xrCreateAction grip_pose")?;
        let select = set
            .create_action::<f32>("select", "Select", &hands)
            .call("xrCreateAction select")?;
        let squeeze = set
            .create_action::<f32>("squeeze", "Squeeze", &hands)
            .call("xrCreateAction squeeze")?;
        let stick = set
            .create_action::<xr::Vector2f>("thumbstick", "Thumbstick", &hands)
            .call("xrCreateAction thumbstick")?;
        let stick_click = set
            .create_action::<bool>("thumbstick_click", "Thumbstick click", &hands)
            .call("xrCreateAction thumbstick_click")?;
        let menu = set
            .create_action::<bool>("menu", "Menu", &hands)
            .call("xrCreateAction menu")?;
        let haptic = set
            .create_action::<xr::Haptic>("haptic", "Haptic", &hands)
            .call("xrCreateAction haptic")?;
        let mut suggested = Vec::new();
        for p in binding_table() {
            if let Some(ext) = p.extension {
                if !extension_enabled(exts, ext) {
                    tracing::info!(
                        "bindings for {} skipped: the runtime does not offer {ext}",
                        p.profile
                    );
                    continue;
                }
            }
            if p.profile.ends_with("/meta/touch_plus_controller") && api < xr::Version::new(1, 1, 0)
            {
                tracing::info!("bindings for {} skipped: the profile is OpenXR 1.1 core and the instance is {api}", p.profile);
                continue;
            }
            match Self::suggest(
                instance,
                &p,
                [&aim, &grip],
                [&select, &squeeze],
                &stick,
                [&stick_click, &menu],
                &haptic,
            ) {
                Ok(()) => suggested.push(p.profile.to_string()),
                Err(r) => tracing::info!(
                    "bindings for {} skipped: the runtime rejected them ({r})",
                    p.profile
                ),
            }
        }
        let [la, ra] = hands;
        let space = |a: &xr::Action<xr::Posef>, hand: xr::Path, what: &str| {
            a.create_space(session, hand, xr::Posef::IDENTITY)
                .call(what)
        };
        let aim_spaces = [
            space(&aim, la, "xrCreateActionSpace aim left")?,
            space(&aim, ra, "xrCreateActionSpace aim right")?,
        ];
        let grip_spaces = [
            space(&grip, la, "xrCreateActionSpace grip left")?,
            space(&grip, ra, "xrCreateActionSpace grip right")?,
        ];
        session
            .attach_action_sets(&[&set])
            .call("xrAttachSessionActionSets")?;
        Ok(Controls {
            aim_spaces,
            grip_spaces,
            select,
            squeeze,
            stick,
            stick_click,
            menu,
            haptic,
            set,
            hands,
            suggested,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn suggest(
        instance: &xr::Instance,
        p: &ProfileBindings,
        poses: [&xr::Action<xr::Posef>; 2],
        floats: [&xr::Action<f32>; 2],
        stick: &xr::Action<xr::Vector2f>,
        bools: [&xr::Action<bool>; 2],
        haptic: &xr::Action<xr::Haptic>,
    ) -> std::result::Result<(), xr::sys::Result> {
        let profile = instance.string_to_path(p.profile)?;
        let mut bindings = Vec::new();
        for (slot, l, r) in &p.bindings {
            for (hand, suffix) in [(0, l), (1, r)] {
                let Some(suffix) = suffix else { continue };
                let side = if hand == 0 { "left" } else { "right" };
                let path = instance.string_to_path(&format!("/user/hand/{side}{suffix}"))?;
                bindings.push(match slot {
                    Slot::Aim => xr::Binding::new(poses[0], path),
                    Slot::Grip => xr::Binding::new(poses[1], path),
                    Slot::Select => xr::Binding::new(floats[0], path),
                    Slot::Squeeze => xr::Binding::new(floats[1], path),
                    Slot::Stick => xr::Binding::new(stick, path),
                    Slot::StickClick => xr::Binding::new(bools[0], path),
                    Slot::Menu => xr::Binding::new(bools[1], path),
                    Slot::Haptic => xr::Binding::new(haptic, path),
                });
            }
        }
        instance.suggest_interaction_profile_bindings(profile, &bindings)
    }

    /// Syncs the actions and reads both hands at `time`, poses located in
    /// `base` (the tracking space). A pose counts only when the runtime
    /// marks both its orientation and position valid.
    pub fn read(
        &self,
        session: &xr::Session<xr::Vulkan>,
        base: &xr::Space,
        time: xr::Time,
    ) -> Result<[HandInput; 2]> {
        session
            .sync_actions(&[xr::ActiveActionSet::new(&self.set)])
            .call("xrSyncActions")?;
        let mut out = [HandInput::default(); 2];
        for (i, h) in out.iter_mut().enumerate() {
            let hand = self.hands[i];
            let locate = |s: &xr::Space, what: &str| -> Result<Option<crate::view::Pose>> {
                let l = s.locate(base, time).call(what)?;
                let valid = l.location_flags.contains(
                    xr::SpaceLocationFlags::ORIENTATION_VALID
                        | xr::SpaceLocationFlags::POSITION_VALID,
                );
                Ok(valid
                    .then(|| pose_of(&l.pose))
                    .filter(|p| p.validate().is_ok())
                    .map(|p| crate::view::Pose {
                        orientation: p.orientation.normalize(),
                        ..p
                    }))
            };
            h.aim = locate(&self.aim_spaces[i], "xrLocateSpace aim")?;
            h.grip = locate(&self.grip_spaces[i], "xrLocateSpace grip")?;
            let f = |a: &xr::Action<f32>, what: &str| -> Result<f32> {
                let s = a.state(session, hand).call(what)?;
                Ok(if s.is_active { s.current_state } else { 0.0 })
            };
            let b = |a: &xr::Action<bool>, what: &str| -> Result<bool> {
                let s = a.state(session, hand).call(what)?;
                Ok(s.is_active && s.current_state)
            };
            h.select = f(&self.select, "xrGetActionStateFloat select")?;
            h.squeeze = f(&self.squeeze, "xrGetActionStateFloat squeeze")?;
            let s = self
                .stick
                .state(session, hand)
                .call("xrGetActionStateVector2f thumbstick")?;
            if s.is_active {
                h.stick = [s.current_state.x, s.current_state.y];
            }
            h.stick_click = b(
                &self.stick_click,
                "xrGetActionStateBoolean thumbstick_click",
            )?;
            h.menu = b(&self.menu, "xrGetActionStateBoolean menu")?;
        }
        Ok(out)
    }

    /// A short haptic tick (20 ms at half amplitude) on `hand` (0 left, 1 right).
    pub fn tick(&self, session: &xr::Session<xr::Vulkan>, hand: usize) -> Result<()> {
        let v = xr::HapticVibration::new()
            .amplitude(0.5)
            .duration(xr::Duration::from_nanos(20_000_000))
            .frequency(xr::FREQUENCY_UNSPECIFIED);
        self.haptic
            .apply_feedback(session, self.hands[hand], &v)
            .call("xrApplyHapticFeedback")
    }

    /// The current interaction profile per hand (None: no device bound).
    pub fn profiles(
        &self,
        instance: &xr::Instance,
        session: &xr::Session<xr::Vulkan>,
    ) -> Result<[Option<String>; 2]> {
        let mut out = [None, None];
        for (i, o) in out.iter_mut().enumerate() {
            let p = session
                .current_interaction_profile(self.hands[i])
                .call("xrGetCurrentInteractionProfile")?;
            if p != xr::Path::NULL {
                *o = Some(instance.path_to_string(p).call("xrPathToString")?);
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_profile_binds_both_poses_on_both_hands_and_valid_paths() {
        let t = binding_table();
        assert_eq!(t.len(), 9);
        for p in &t {
            assert!(
                p.profile.starts_with("/interaction_profiles/"),
                "{}",
                p.profile
            );
            for want in [Slot::Aim, Slot::Grip, Slot::Select] {
                assert!(
                    p.bindings
                        .iter()
                        .any(|(s, l, r)| *s == want && l.is_some() && r.is_some()),
                    "{} lacks {want:?}",
                    p.profile
                );
            }
            for (_, l, r) in &p.bindings {
                for path in [l, r].into_iter().flatten() {
                    assert!(path.starts_with("/input/") || path.starts_with("/output/"));
                    assert!(path
                        .chars()
                        .all(|c| c.is_ascii_lowercase() || "/_".contains(c)));
                }
            }
        }
    }
}
