//! The OpenXR session loop: the application side of a session, on top of
//! the [`crate::xr`] wrapper. Instance (with XR_KHR_vulkan_enable2), the
//! Vulkan device made through the runtime, a session driven by the
//! lifecycle machine, swapchains the renderer's frames are copied into, and
//! the frame loop in the order the spec asks for (OpenXR 1.0 §10.4): poll
//! events → xrWaitFrame → xrBeginFrame → xrLocateViews at the predicted
//! display time → cull → record → acquire and wait the swapchain images →
//! submit → release → xrEndFrame. With frames in flight, submitting does not
//! wait for the GPU: xrWaitFrame paces the loop, and a frame's record is
//! completed when its fence signals.

use super::headless::{load_scene, SceneCounts};
use super::mirror::{Desk, Mirror};
use super::session::{
    write_capture, FrameRecord, HandProfiles, OriginFile, RecordQueue, RunArgs, RunStats,
};
use crate::error::{Error, Result};
use crate::gpu::surface::Source;
use crate::gpu::{Context, Validation};
use crate::interact::raycast::SceneQuery;
use crate::interact::{FrameInput, Interaction};
use crate::render::driver::FrameDriver;
use crate::render::{FrameOutput, OutputSpec, Renderer};
use crate::scene::Scene;
use crate::view::{Fov, HiddenArea, Pose, PoseFile, StereoRig};
use crate::xr::actions::Controls;
use crate::xr::instance::{connect, Connection};
use crate::xr::state::{Action, QuitAction, SessionMachine};
use crate::xr::watchdog::Watchdog;
use crate::xr::{
    fetch_masks, sanitize_views, state_of, tracking_head, vulkan, world_rig, xr_err, Chain,
    Messenger, TrackedView, XrCall, CALL_LIMIT,
};
use ash::vk;
use openxr as xr;
use openxr::sys;
use std::sync::Arc;
use std::time::{Duration, Instant};

mod app;
mod protocol;
mod setup;

/// Everything a session owns, declared in teardown order (Rust drops fields
/// in declaration order): the mirror and the panel, the OpenXR handles
/// ([`Runtime`]), then the renderer (which waits for the device to go idle
/// before destroying its Vulkan objects); the Vulkan context, held by the
/// caller, goes last. The watchdog is last so it also covers a teardown
/// that blocks.
struct Live {
    /// The mirror window's Vulkan side goes first: dropping it waits for
    /// the device, so its copies are done before the swapchains go.
    mirror: Option<Mirror>,
    /// The in-headset panel (made when the menu first opens it); its
    /// swapchain goes before the session.
    panel: Option<super::xr_panel::XrPanel>,
    rt: Runtime,
    driver: Option<FrameDriver>,
    watchdog: Watchdog,
}

/// The OpenXR side of a session: its handles in teardown order
/// (swapchains, space, session, messenger, instance) and what the frame
/// protocol keeps from frame to frame.
pub(super) struct Runtime {
    controls: Option<Controls>,
    color: Vec<Chain>,
    depth: Vec<Chain>,
    /// With quad views: the insets' colour swapchains (as `color`).
    inset: Vec<Chain>,
    space: Option<xr::Space>,
    stream: Option<xr::FrameStream<xr::Vulkan>>,
    waiter: Option<xr::FrameWaiter>,
    session: Option<xr::Session<xr::Vulkan>>,
    messenger: Option<Messenger>,
    instance: Option<xr::Instance>,
    /// The session's view configuration (stereo, or quad views with the
    /// inset).
    view_type: xr::ViewConfigurationType,
    blend: xr::EnvironmentBlendMode,
    /// The runtime takes the eyes' depth (a depth swapchain exists).
    with_depth: bool,
    /// The last valid pose and FOV of each view, standing in for invalid
    /// ones.
    last_valid: Vec<Option<TrackedView>>,
}

impl Drop for Live {
    fn drop(&mut self) {
        self.watchdog.arm("tearing down the OpenXR session");
    }
}

/// Runs the scene in an OpenXR session until the runtime ends it, a quit
/// is requested or the frame/time limit is reached (then it asks the
/// runtime to exit and follows the session down to EXITING). `stats` is
/// filled as the session goes. No runtime or headset is
/// [`Error::XrUnavailable`].
pub fn run_session(args: &RunArgs, stats: &mut RunStats, desk: &mut Desk) -> Result<()> {
    let inset_out = desk.live.config.effort.inset.is_some_and(|i| !i.composite);
    let mut conn = connect(inset_out)?;
    setup::record_runtime(&conn, stats);
    let views = setup::choose_views(&conn, inset_out, stats)?;
    let blend = setup::blend_mode(&conn, &views)?;
    setup::check_vulkan(&conn)?;
    let (scene, _) = load_scene(&args.scene)?;
    let extent = setup::eye_extent(args.size, &views.config);
    // The mirror window first: its surface's extensions go into the create
    // infos handed to the runtime (XR_KHR_vulkan_enable2), which adds its
    // own; some runtimes would not add these.
    let system_name = conn.system_props.system_name.clone();
    let extra = desk.prepare(
        &format!("vergence run: {} ({system_name})", scene.name),
        extent,
    );
    let factory = vulkan::XrDeviceFactory {
        instance: &conn.instance,
        system: conn.system,
    };
    let ctx = Arc::new(Context::with_extensions(
        Validation::from_env(),
        &factory,
        &extra,
    )?);
    stats.device = ctx.device_name.clone();
    stats.driver = ctx.driver.clone();
    stats.scene = Some(SceneCounts::of(&scene));
    let (session, waiter, stream) = setup::create_session(&conn, &ctx)?;
    let mut live = Live::new(&mut conn, &session, (waiter, stream), views.view_type);
    let space = setup::reference_space(&conn, &session, stats)?;
    live.rt.controls = controls(&conn, &session, stats);
    let (color_format, depth_format) =
        setup::swapchain_formats(&conn, &session, views.quad, &ctx, stats)?;
    stats.image_size = [extent.width, extent.height];
    // With aq the swapchain images hold the largest render scale; each
    // frame's sub-image is the part it rendered.
    let mut chains = ChainSpec {
        color_format,
        depth_format,
        extent,
        nominal: extent,
        max: setup::max_extent(&views.config),
        quad: views.quad,
    };
    chains.extent = chains.images_for(desk.live.config.effort.aq)?;
    let config = desk.live.config.clone();
    chains.create(&session, &mut live, &config)?;
    live.rt.space = Some(space);
    live.rt.blend = blend;
    live.rt.with_depth = chains.depth_format.is_some();
    if args.interact.panel && stats.panel.is_none() {
        stats.panel = Some(super::xr_panel::PanelStats {
            size_px: super::panel::SIZE_PX,
            size_m: crate::interact::panel::SIZE_M,
            ..Default::default()
        });
    }
    live.mirror = desk.mirror(&ctx, color_format);
    if let Some(m) = &mut live.mirror {
        m.set_title(&format!(
            "vergence run: {} [{}]",
            scene.name,
            config.opt_string()
        ));
    }
    let renderer =
        Renderer::with_output(ctx.clone(), &scene, &config, extent, Some(chains.output()))?;
    stats.config = renderer.config.clone();
    stats.renderer = renderer.report();
    live.driver = Some(FrameDriver::new(renderer, &scene)?);
    let masks = match conn.exts.khr_visibility_mask {
        true => Some(Arc::new(fetch_masks(&session, views.view_type, 2)?)),
        false => None,
    };
    stats.visibility_mask = masks
        .iter()
        .flat_map(|m| m.iter().map(|a| [a.vertices.len(), a.indices.len()]))
        .collect();
    let mut state = LoopState::new(args, &scene, desk, chains, &views, stats)?;
    state.masks = masks;
    let result = frame_loop(stats, &mut live, &mut state);
    let result = finish_session(stats, &mut live, &mut state, &ctx, result);
    // Teardown: OpenXR handles first (the session's last references go
    // with `live`), then the renderer waits for the device and destroys its
    // objects, then the context destroys device and instance.
    drop(session);
    drop(conn);
    drop(live);
    drop(ctx);
    result
}

/// The controllers' actions; without them (an error is logged) the
/// session is head-only.
fn controls(
    conn: &Connection,
    session: &xr::Session<xr::Vulkan>,
    stats: &mut RunStats,
) -> Option<Controls> {
    match Controls::new(&conn.instance, session, &conn.exts, conn.api_version) {
        Ok(c) => {
            stats.suggested_profiles = c.suggested.clone();
            Some(c)
        }
        Err(e) => {
            tracing::warn!("no controller input (head-only): {e}");
            None
        }
    }
}

/// After the frame loop: the frames in flight finish (their records join
/// the log) before the swapchains they were copied into go away; the
/// mirror writes its screenshot (the last frame) on request and goes back
/// to the desk; the memory and validation counts are recorded. The first
/// error wins.
fn finish_session(
    stats: &mut RunStats,
    live: &mut Live,
    state: &mut LoopState,
    ctx: &Context,
    mut result: Result<()>,
) -> Result<()> {
    stats.origin = Some(OriginFile::from(&state.interaction.origin));
    if let Some(driver) = live.driver.as_mut() {
        let finished = driver.finish();
        while let Some(r) = driver.take_completed() {
            state.records.complete(&r, stats);
        }
        let flushed = state.records.flush_all(stats);
        if result.is_ok() {
            result = finished.and(flushed);
        }
    }
    if let Some(mut m) = live.mirror.take() {
        let shot = match (&state.args.screenshot, &result) {
            (Some(path), Ok(())) => m.write_screenshot(path),
            _ => Ok(()),
        };
        state.desk.put_back(m);
        if result.is_ok() {
            result = shot;
        }
    }
    stats.sample_memory(ctx, true);
    // Added, not assigned: with --reconnect a run holds several sessions.
    stats.validation_messages += ctx.validation_messages();
    stats.xr_validation_messages += live.rt.messenger.as_ref().map_or(0, Messenger::count);
    if stats.xr_validation_messages > 0 {
        if let Some(m) = &live.rt.messenger {
            for line in m.first_messages() {
                eprintln!("OpenXR validation: {line}");
            }
        }
    }
    result
}

impl Live {
    /// The session's handles, nothing else yet (the set-up fills the rest;
    /// the debug messenger moves here from the connection).
    fn new(
        conn: &mut Connection,
        session: &xr::Session<xr::Vulkan>,
        (waiter, stream): (xr::FrameWaiter, xr::FrameStream<xr::Vulkan>),
        view_type: xr::ViewConfigurationType,
    ) -> Live {
        Live {
            mirror: None,
            panel: None,
            rt: Runtime {
                controls: None,
                color: Vec::new(),
                depth: Vec::new(),
                inset: Vec::new(),
                space: None,
                stream: Some(stream),
                waiter: Some(waiter),
                session: Some(session.clone()),
                messenger: conn.messenger.take(),
                instance: Some(conn.instance.clone()),
                view_type,
                blend: xr::EnvironmentBlendMode::OPAQUE,
                with_depth: false,
                last_valid: Vec::new(),
            },
            driver: None,
            watchdog: Watchdog::start(CALL_LIMIT),
        }
    }
}

impl<'a> LoopState<'a> {
    /// The loop's state at the first frame: the viewpoints and the tools
    /// (`--section` is where the plane starts), a kiosk's idle watch, and
    /// with quad views the focus views' recommended sizes (unless
    /// `--width`/`--height` set the eye size).
    fn new(
        args: &'a RunArgs,
        scene: &'a Scene,
        desk: &'a mut Desk,
        chains: ChainSpec,
        views: &setup::Views,
        stats: &mut RunStats,
    ) -> Result<LoopState<'a>> {
        // No view has been located yet; a typical headset FOV frames the scene.
        let places = super::viewpoints::plan(args, scene, &Fov::symmetric(0.8, 0.8))?;
        stats.viewpoints = places.iter().map(|v| v.name.clone()).collect();
        let mut interaction = super::viewpoints::interaction(&places, args.interact);
        interaction.section = stats
            .config
            .frame
            .section
            .map(crate::render::culling::plane_of);
        let px = |v: &xr::ViewConfigurationView| {
            (
                v.recommended_image_rect_width,
                v.recommended_image_rect_height,
            )
        };
        let focus_px = (views.quad && args.size.is_none())
            .then(|| [px(&views.config[2]), px(&views.config[3])]);
        Ok(LoopState {
            args,
            scene,
            opt: desk.live.config.opt_string(),
            desk,
            chains,
            idle: args
                .kiosk
                .as_ref()
                .and_then(|k| k.idle_return_s)
                .map(super::kiosk::IdleWatch::new),
            records: RecordQueue::default(),
            masks: None,
            interaction,
            query: SceneQuery::new(scene),
            overlay: Vec::new(),
            last_display_ns: None,
            first_fov_recorded: false,
            motion_origin_ns: None,
            lens: None,
            pending_toggle: None,
            focus_px,
            pending_resize: None,
            last_times: None,
            panel_drawn: false,
            last_shown: None,
            rehearsal: None,
            captured: false,
            desk_controllers: args
                .desk_controllers
                .then(super::desk_controllers::DeskControllers::new),
        })
    }
}

/// The swapchains' formats and size (kept to make them again when a live
/// toggle switches the stereo mode).
#[derive(Clone, Copy)]
struct ChainSpec {
    color_format: vk::Format,
    depth_format: Option<vk::Format>,
    /// The swapchain images' size (with aq, the largest render scale's).
    extent: vk::Extent2D,
    /// The eye size the renderer is made for (aq's scale 1).
    nominal: vk::Extent2D,
    /// The runtime's largest image per view.
    max: (u32, u32),
    /// The session takes quad views: the wide views and the insets get
    /// swapchains of their own.
    quad: bool,
}

impl ChainSpec {
    /// The swapchain image size a configuration needs: the eye size, or
    /// with aq the largest render scale's (an error where the runtime
    /// allows less).
    fn images_for(&self, aq: bool) -> Result<vk::Extent2D> {
        if !aq {
            return Ok(self.nominal);
        }
        let h = crate::render::scaled(self.nominal, crate::adaptive::MAX_SCALE);
        if h.width > self.max.0 || h.height > self.max.1 {
            return Err(Error::config(
                "--opt aq",
                format!(
                    "aq renders up to {}x{} per eye ({}x the eye size {}x{}) and the runtime allows at most {}x{}: give a smaller --width/--height",
                    h.width,
                    h.height,
                    crate::adaptive::MAX_SCALE,
                    self.nominal.width,
                    self.nominal.height,
                    self.max.0,
                    self.max.1
                ),
            ));
        }
        Ok(h)
    }

    /// What the renderer copies each frame into.
    fn output(&self) -> OutputSpec {
        OutputSpec {
            color_format: self.color_format,
            depth: self.depth_format.is_some(),
            quad: self.quad,
        }
    }

    /// The colour (and depth) swapchains for `config`'s stereo mode: one
    /// of two-layer images under multiview, one per eye in two-pass. With
    /// quad views the colour swapchains hold the wide views (F × the
    /// images' size) and as many again the insets (up to the images' size).
    fn create(
        &self,
        session: &xr::Session<xr::Vulkan>,
        live: &mut Live,
        config: &crate::config::RenderConfig,
    ) -> Result<()> {
        let multiview = config.frame.stereo == crate::config::StereoMode::Multiview;
        let (sets, layers) = if multiview { (1, 2) } else { (2, 1) };
        let color_usage = xr::SwapchainUsageFlags::COLOR_ATTACHMENT
            | xr::SwapchainUsageFlags::TRANSFER_DST
            | xr::SwapchainUsageFlags::TRANSFER_SRC;
        let wide = match (self.quad, config.effort.inset) {
            (true, Some(i)) => crate::render::scaled(self.extent, i.wide_scale),
            (true, None) => {
                return Err(Error::config(
                    "--opt",
                    "the session takes quad views, which need inset: it cannot be turned off in this session",
                ))
            }
            (false, _) => self.extent,
        };
        live.rt.color.clear();
        live.rt.depth.clear();
        live.rt.inset.clear();
        for _ in 0..sets {
            live.rt.color.push(Chain::new(
                session,
                self.color_format,
                color_usage,
                wide,
                layers,
            )?);
            if self.quad {
                live.rt.inset.push(Chain::new(
                    session,
                    self.color_format,
                    color_usage,
                    self.extent,
                    layers,
                )?);
            }
            if let Some(df) = self.depth_format {
                live.rt.depth.push(Chain::new(
                    session,
                    df,
                    xr::SwapchainUsageFlags::DEPTH_STENCIL_ATTACHMENT
                        | xr::SwapchainUsageFlags::TRANSFER_DST,
                    self.extent,
                    layers,
                )?);
            }
        }
        Ok(())
    }
}

/// What the frame loop carries from frame to frame.
struct LoopState<'a> {
    args: &'a RunArgs,
    scene: &'a Scene,
    /// The mirror's run-long side and the live configuration.
    desk: &'a mut Desk,
    chains: ChainSpec,
    /// The current configuration's `--opt` string, for the frame records.
    opt: String,
    /// A kiosk's return to the spawn when the head stays still.
    idle: Option<super::kiosk::IdleWatch>,
    /// Records of frames whose GPU times are still to come.
    records: RecordQueue,
    masks: Option<Arc<Vec<HiddenArea>>>,
    /// Locomotion, pointing, measuring: the tracking origin and the tools.
    interaction: Interaction,
    /// The scene prepared for ray casts.
    query: SceneQuery<'a>,
    /// This frame's overlay boxes (reused from frame to frame).
    overlay: Vec<crate::interact::overlay::OverlayBox>,
    /// The previous rendered frame's predicted display time (for dt).
    last_display_ns: Option<i64>,
    first_fov_recorded: bool,
    /// The predicted display time of the first rendered frame: moving
    /// instances run on display time from there.
    motion_origin_ns: Option<i64>,
    lens: Option<(Vec<Fov>, Arc<Vec<HiddenArea>>)>,
    /// A panel button's toggle, switched at the top of the next frame.
    pending_toggle: Option<super::toggles::Toggle>,
    /// With quad views: the focus views' recommended sizes (left, right),
    /// until the first located frame has set the eye size from them.
    focus_px: Option<[(u32, u32); 2]>,
    /// A larger eye size for the focus views' density, applied at the top
    /// of the next frame.
    pending_resize: Option<vk::Extent2D>,
    /// The last finished frame's GPU and CPU ms and the budget (the
    /// panel's status line).
    last_times: Option<(f64, f64, f64)>,
    /// The panel was drawn this frame: its quad goes into xrEndFrame.
    panel_drawn: bool,
    /// The last recorded frame's world rig and scene time (F4 measures it).
    last_shown: Option<(StereoRig, f64)>,
    /// `--rehearse`: the script playing since the first focus.
    rehearsal: Option<super::rehearse::Player>,
    /// `--capture` has written its frame.
    captured: bool,
    /// `--desk-controllers`: the mirror's keys sent to the remote driver.
    desk_controllers: Option<super::desk_controllers::DeskControllers>,
}

impl LoopState<'_> {
    /// Without XR_KHR_visibility_mask: the lens-ellipse default for the
    /// rig's FOVs, rebuilt only when they change.
    fn lens_default(&mut self, rig: &StereoRig) -> Arc<Vec<HiddenArea>> {
        let fovs: Vec<Fov> = rig.views.iter().map(|v| v.fov).collect();
        match &self.lens {
            Some((f, m)) if *f == fovs => m.clone(),
            _ => {
                let m = Arc::new(
                    fovs.iter()
                        .map(crate::view::lens::default_hidden_area)
                        .collect::<Vec<_>>(),
                );
                self.lens = Some((fovs, m.clone()));
                m
            }
        }
    }
}

fn frame_loop(stats: &mut RunStats, live: &mut Live, st: &mut LoopState) -> Result<()> {
    let mut machine = SessionMachine::default();
    let session_started = Instant::now();
    stats.begin_session();
    let result = run_frames(stats, live, st, &mut machine);
    stats.duration_s += session_started.elapsed().as_secs_f64();
    stats.focused = machine.was_focused();
    match result {
        Ok(reason) => {
            stats.exit = reason;
            Ok(())
        }
        Err(e) => {
            stats.exit = e.to_string();
            Err(e)
        }
    }
}

/// The session's loop: the desk's work, a requested quit, the runtime's
/// events, then a frame while frames are due. Returns why the session
/// ended.
fn run_frames(
    stats: &mut RunStats,
    live: &mut Live,
    st: &mut LoopState,
    machine: &mut SessionMachine,
) -> Result<String> {
    let session = live.rt.session.clone().expect("set");
    // --seconds counts from the run's start, across reconnects.
    let started = stats.run_started();
    let mut index = 0u64;
    loop {
        desk_work(live, stats, st, &session, index)?;
        let rehearsed = rehearsal(st, machine.was_focused())?;
        let quit = crate::quit::requested()
            || rehearsed
            || st.desk.closed
            || st.desk.next_scene
            || st.args.limit_reached(stats.frames_submitted, started);
        if quit {
            match machine.on_quit() {
                QuitAction::RequestExit => {
                    let _w = live.watchdog.watch("xrRequestExitSession");
                    session.request_exit().call("xrRequestExitSession")?;
                }
                QuitAction::Leave => return Ok("quit before the session ran".into()),
                QuitAction::Wait => {}
            }
        }
        if let Some(reason) = poll_events(stats, live, st, machine)? {
            return Ok(reason);
        }
        stats.focused = machine.was_focused();
        if !machine.frames_due() {
            std::thread::sleep(Duration::from_millis(5));
            continue;
        }
        let mut app = app::SessionApp {
            mirror: &mut live.mirror,
            panel: &mut live.panel,
            driver: &mut live.driver,
            watchdog: &live.watchdog,
            stats,
            st,
        };
        protocol::one_frame(&mut live.rt, &live.watchdog, &mut app, index)?;
        index += 1;
    }
}

/// `--rehearse`: the script starts playing at the session's first focus.
/// Returns whether it has played out (the run then ends); an error when it
/// stopped early.
fn rehearsal(st: &mut LoopState, focused: bool) -> Result<bool> {
    let Some(script) = &st.args.rehearse else {
        return Ok(false);
    };
    let player = match &st.rehearsal {
        Some(p) => p,
        None if focused => st
            .rehearsal
            .insert(super::rehearse::Player::start(script.clone())),
        None => return Ok(false),
    };
    match player.take_error() {
        Some(e) => Err(e),
        None => Ok(player.finished()),
    }
}

/// The desk's work before a frame: the mirror's keys (a switched
/// configuration) and its error measure, a pending eye resize and a
/// panel's pending toggle.
fn desk_work(
    live: &mut Live,
    stats: &mut RunStats,
    st: &mut LoopState,
    session: &xr::Session<xr::Vulkan>,
    index: u64,
) -> Result<()> {
    if st.desk_controllers.is_some() && live.mirror.is_none() {
        return Err(Error::config(
            "--desk-controllers",
            "no mirror window opened (is there a display?): the keys are read in it",
        ));
    }
    if let Some(m) = live.mirror.as_mut() {
        let switched = st.desk.handle(m, index);
        if let Some(d) = st.desk_controllers.as_mut() {
            d.step(&st.desk.held)?;
        }
        if let Some(d) = live.driver.as_ref() {
            let section = st
                .interaction
                .section
                .map(|p| [p.normal.x, p.normal.y, p.normal.z, p.d]);
            st.desk.measure_error(
                m,
                d.renderer().context(),
                st.scene,
                st.last_shown.as_ref().map(|(r, t)| (r, *t)),
                st.chains.nominal,
                section,
            );
        }
        st.desk.keep_pose(st.last_shown.as_ref().map(|(r, _)| r));
        if let Some(new) = switched {
            switch_config(live, stats, st, session, new)?;
        }
    }
    if let Some(nominal) = st.pending_resize.take() {
        resize_eyes(live, stats, st, session, nominal)?;
    }
    if let Some(t) = st.pending_toggle.take() {
        if let Some(new) = st.desk.live.switch(t, index) {
            switch_config(live, stats, st, session, new)?;
        }
    }
    Ok(())
}

/// Drains the runtime's event queue. Returns why the session ended when
/// it did (it exited), None while it goes on.
fn poll_events(
    stats: &mut RunStats,
    live: &mut Live,
    st: &mut LoopState,
    machine: &mut SessionMachine,
) -> Result<Option<String>> {
    let instance = live.rt.instance.clone().expect("set");
    let mut buf = xr::EventDataBuffer::new();
    loop {
        let event = {
            let _w = live.watchdog.watch("xrPollEvent");
            instance.poll_event(&mut buf).call("xrPollEvent")?
        };
        let Some(event) = event else {
            return Ok(None);
        };
        if let xr::Event::SessionStateChanged(e) = event {
            if let Some(reason) = on_state(stats, live, st, machine, e.state())? {
                return Ok(Some(reason));
            }
            continue;
        }
        on_event(stats, live, st, &instance, event)?;
    }
}

/// A session state change: begins or ends the session as the state
/// machine says; the session's exit is its end (with the reason), a loss
/// pending an error.
fn on_state(
    stats: &mut RunStats,
    live: &Live,
    st: &LoopState,
    machine: &mut SessionMachine,
    state: xr::SessionState,
) -> Result<Option<String>> {
    let state = state_of(state);
    stats.states.push(format!("{state:?}").to_uppercase());
    tracing::info!("session state {state:?}");
    let session = live.rt.session.as_ref().expect("set");
    let action = machine.on_state(state);
    match action {
        Action::Begin => {
            let _w = live.watchdog.watch("xrBeginSession");
            session.begin(live.rt.view_type).call("xrBeginSession")?;
        }
        Action::End => {
            let _w = live.watchdog.watch("xrEndSession");
            session.end().call("xrEndSession")?;
        }
        Action::Exit => {
            machine.performed(action);
            let reason = match (machine.exit_requested, st.desk.closed, st.desk.next_scene) {
                (true, true, _) => "session exited after the mirror window was closed",
                (true, _, true) => "session exited for the next scene",
                (true, ..) => "session exited after vergence asked to exit",
                (false, ..) => "the runtime ended the session",
            };
            return Ok(Some(reason.into()));
        }
        Action::Lost => {
            machine.performed(action);
            return Err(xr_err(
                "the session is being lost (XR_SESSION_STATE_LOSS_PENDING)",
                sys::Result::ERROR_SESSION_LOST,
            ));
        }
        Action::None => {}
    }
    machine.performed(action);
    Ok(None)
}

/// Any other event: an instance loss pending (an error), lost events
/// counted, a new visibility mask fetched, the interaction profiles
/// recorded, a pending reference-space change logged.
fn on_event(
    stats: &mut RunStats,
    live: &Live,
    st: &mut LoopState,
    instance: &xr::Instance,
    event: xr::Event,
) -> Result<()> {
    let session = live.rt.session.as_ref().expect("set");
    match event {
        xr::Event::InstanceLossPending(_) => {
            return Err(xr_err(
                "the OpenXR instance is being lost (XrEventDataInstanceLossPending)",
                sys::Result::ERROR_INSTANCE_LOST,
            ));
        }
        xr::Event::EventsLost(e) => {
            stats.events_lost += e.lost_event_count() as u64;
            tracing::warn!(
                "the runtime's event queue overflowed: {} events lost",
                e.lost_event_count()
            );
        }
        xr::Event::VisibilityMaskChangedKHR(_) => {
            st.masks = Some(Arc::new(fetch_masks(session, live.rt.view_type, 2)?));
            stats.visibility_mask_refreshes += 1;
        }
        xr::Event::InteractionProfileChanged(_) => {
            if let Some(c) = &live.rt.controls {
                let _w = live.watchdog.watch("xrGetCurrentInteractionProfile");
                let [left, right] = c.profiles(instance, session)?;
                tracing::info!(
                    "interaction profiles: left {}, right {}",
                    left.as_deref().unwrap_or("none"),
                    right.as_deref().unwrap_or("none")
                );
                stats.interaction_profiles = HandProfiles { left, right };
            }
        }
        xr::Event::ReferenceSpaceChangePending(_) => {
            tracing::info!("the reference space is about to change (recentre)");
        }
        _ => {}
    }
    Ok(())
}

/// Takes the renderer out of the session before it is made again: its
/// frames in flight finish (their records join the log), the mirror's
/// copies too, and it is destroyed (waiting for the device). Its device
/// context and configuration, or None without a renderer.
fn retire_driver(
    live: &mut Live,
    stats: &mut RunStats,
    st: &mut LoopState,
) -> Result<Option<(Arc<Context>, crate::config::RenderConfig)>> {
    let Some(mut driver) = live.driver.take() else {
        return Ok(None);
    };
    let finished = driver.finish();
    while let Some(r) = driver.take_completed() {
        st.records.complete(&r, stats);
    }
    finished?;
    let mirror = &mut live.mirror;
    st.records.flush(stats, |i, t| {
        if let Some(m) = mirror.as_mut() {
            m.push_record(i, t);
        }
    })?;
    if let Some(m) = live.mirror.as_mut() {
        m.finish()?;
    }
    let old = driver.renderer().config.clone();
    let ctx = driver.renderer().context().clone();
    Ok(Some((ctx, old)))
}

/// Renders from the next frame on with `config` (a live toggle): the frames
/// in flight finish (their records join the log), the renderer is made
/// again, and the swapchains too when the stereo mode changed; the session,
/// the space, the actions and the window stay. A renderer that cannot be
/// made with `config` is reported on one line and the old one comes back.
fn switch_config(
    live: &mut Live,
    stats: &mut RunStats,
    st: &mut LoopState,
    session: &xr::Session<xr::Vulkan>,
    config: crate::config::RenderConfig,
) -> Result<()> {
    let Some((ctx, old)) = retire_driver(live, stats, st)? else {
        return Ok(());
    };
    let scene = st.scene;
    // New swapchains when the stereo mode changed or aq needs larger (or
    // no longer larger) images.
    let make = |live: &mut Live,
                chains: &mut ChainSpec,
                c: &crate::config::RenderConfig|
     -> Result<FrameDriver> {
        if chains.quad && c.effort.inset.is_some_and(|i| i.composite) {
            return Err(Error::config(
                "--opt inset-composite",
                "this session submits the four views (its view configuration is fixed): inset-composite applies from the next session",
            ));
        }
        let images = chains.images_for(c.effort.aq)?;
        let wide_changed = chains.quad
            && c.effort.inset.map(|i| i.wide_scale) != old.effort.inset.map(|i| i.wide_scale);
        if c.frame.stereo != old.frame.stereo
            || images != chains.extent
            || live.rt.color.is_empty()
            || wide_changed
        {
            chains.extent = images;
            chains.create(session, live, c)?;
        }
        let r =
            Renderer::with_output(ctx.clone(), scene, c, chains.nominal, Some(chains.output()))?;
        FrameDriver::new(r, scene)
    };
    let driver = match make(live, &mut st.chains, &config) {
        Ok(d) => d,
        Err(e) => {
            st.desk.live.revert(old.clone(), &e);
            // The old configuration's swapchains, made again if they went.
            live.rt.color.clear();
            live.rt.depth.clear();
            live.rt.inset.clear();
            make(live, &mut st.chains, &old)?
        }
    };
    stats.renderer = driver.renderer().report();
    live.driver = Some(driver);
    st.opt = st.desk.live.config.opt_string();
    if let Some(m) = &mut live.mirror {
        m.set_title(&format!("vergence run: {} [{}]", st.scene.name, st.opt));
    }
    Ok(())
}

/// The eye size at which the focus views (FOVs `focus`, recommended
/// `px`) get their own density ([`crate::view::inset::focus_density_size`],
/// the larger over the eyes), when it is larger than the current one and
/// the runtime's images (and with aq the largest scale) allow it; else
/// None (the eyes keep their size).
fn focus_density_extent(
    chains: &ChainSpec,
    eyes: &[(Pose, Fov)],
    focus: &[Fov; 2],
    px: [(u32, u32); 2],
) -> Option<vk::Extent2D> {
    let mut need = chains.nominal;
    for ((_, eye), (f, p)) in eyes.iter().zip(focus.iter().zip(px)) {
        let (w, h) = crate::view::inset::focus_density_size(eye, f, p)?;
        need.width = need.width.max(w);
        need.height = need.height.max(h);
    }
    if need == chains.nominal {
        return None;
    }
    let aq = chains.extent != chains.nominal;
    let fits = ChainSpec {
        nominal: need,
        ..*chains
    }
    .images_for(aq);
    match fits {
        Ok(_) => {
            tracing::info!(
                "quad views: the eyes go from {}x{} to {}x{} so that the insets have the focus views' density",
                chains.nominal.width,
                chains.nominal.height,
                need.width,
                need.height
            );
            Some(need)
        }
        Err(e) => {
            tracing::warn!("quad views: the eyes keep their size ({e})");
            None
        }
    }
}

/// Renders from the next frame on at `nominal` pixels per eye: the frames
/// in flight finish (their records join the log), the swapchains and the
/// renderer are made again for the size; the session, the space, the
/// actions and the window stay.
fn resize_eyes(
    live: &mut Live,
    stats: &mut RunStats,
    st: &mut LoopState,
    session: &xr::Session<xr::Vulkan>,
    nominal: vk::Extent2D,
) -> Result<()> {
    let Some((ctx, _)) = retire_driver(live, stats, st)? else {
        return Ok(());
    };
    let config = st.desk.live.config.clone();
    st.chains.nominal = nominal;
    st.chains.extent = st.chains.images_for(config.effort.aq)?;
    st.chains.create(session, live, &config)?;
    let r = Renderer::with_output(ctx, st.scene, &config, nominal, Some(st.chains.output()))?;
    live.driver = Some(FrameDriver::new(r, st.scene)?);
    stats.image_size = [nominal.width, nominal.height];
    Ok(())
}

/// A trigger press on the open panel: the button under the ray does its
/// job (a tool now, a toggle from the next frame, close), logged as events.
fn panel_input(st: &mut LoopState, stats: &mut RunStats, update: &mut crate::interact::Update) {
    use crate::interact::Event;
    let opened = update
        .events
        .iter()
        .filter(|e| matches!(e, Event::Panel { open: true }))
        .count() as u64;
    if let Some(p) = stats.panel.as_mut() {
        p.opened += opened;
    }
    let Some((_, uv)) = update.panel_press else {
        return;
    };
    let Some(button) = super::panel::button_at(uv) else {
        return;
    };
    if let Some(p) = stats.panel.as_mut() {
        p.buttons_pressed += 1;
    }
    update.events.push(Event::PanelButton {
        button: button.name(),
    });
    match button {
        super::panel::Button::Tool(t) => {
            let e = st.interaction.set_tool(t);
            update.events.push(e);
        }
        super::panel::Button::Toggle(t) => st.pending_toggle = Some(t),
        super::panel::Button::Close => update.events.extend(st.interaction.close_panel()),
    }
}
