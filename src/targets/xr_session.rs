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
mod setup;

/// Everything a session owns, declared in teardown order (Rust drops fields
/// in declaration order): OpenXR handles first (swapchains, space, session,
/// messenger, instance), then the renderer (which waits for the device to
/// go idle before destroying its Vulkan objects); the Vulkan context, held
/// by the caller, goes last.
/// The watchdog is last so it also covers a teardown that blocks.
struct Live {
    /// The mirror window's Vulkan side goes first: dropping it waits for
    /// the device, so its copies are done before the swapchains go.
    mirror: Option<Mirror>,
    /// The in-headset panel (made when the menu first opens it); its
    /// swapchain goes before the session.
    panel: Option<super::xr_panel::XrPanel>,
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
    driver: Option<FrameDriver>,
    watchdog: Watchdog,
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
    let inset_out = desk.live.config.inset.is_some_and(|i| !i.composite);
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
    let mut live = Live::new(&mut conn, &session, waiter, stream);
    let space = setup::reference_space(&conn, &session, stats)?;
    live.controls = controls(&conn, &session, stats);
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
    chains.extent = chains.images_for(desk.live.config.aq)?;
    let config = desk.live.config.clone();
    chains.create(&session, &mut live, &config)?;
    live.space = Some(space);
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
    state.blend = blend;
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
    stats.xr_validation_messages += live.messenger.as_ref().map_or(0, Messenger::count);
    if stats.xr_validation_messages > 0 {
        if let Some(m) = &live.messenger {
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
        waiter: xr::FrameWaiter,
        stream: xr::FrameStream<xr::Vulkan>,
    ) -> Live {
        Live {
            mirror: None,
            panel: None,
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
        interaction.section = stats.config.section.map(crate::render::culling::plane_of);
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
            blend: xr::EnvironmentBlendMode::OPAQUE,
            view_type: views.view_type,
            with_depth: chains.depth_format.is_some(),
            last_valid: Vec::new(),
            first_fov_recorded: false,
            motion_origin_ns: None,
            lens: None,
            pending_toggle: None,
            focus_px,
            pending_resize: None,
            last_times: None,
            panel_drawn: false,
            last_shown: None,
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
        let multiview = config.stereo == crate::config::StereoMode::Multiview;
        let (sets, layers) = if multiview { (1, 2) } else { (2, 1) };
        let color_usage = xr::SwapchainUsageFlags::COLOR_ATTACHMENT
            | xr::SwapchainUsageFlags::TRANSFER_DST
            | xr::SwapchainUsageFlags::TRANSFER_SRC;
        let wide = match (self.quad, config.inset) {
            (true, Some(i)) => crate::render::scaled(self.extent, i.wide_scale),
            (true, None) => {
                return Err(Error::config(
                    "--opt",
                    "the session takes quad views, which need inset: it cannot be turned off in this session",
                ))
            }
            (false, _) => self.extent,
        };
        live.color.clear();
        live.depth.clear();
        live.inset.clear();
        for _ in 0..sets {
            live.color.push(Chain::new(
                session,
                self.color_format,
                color_usage,
                wide,
                layers,
            )?);
            if self.quad {
                live.inset.push(Chain::new(
                    session,
                    self.color_format,
                    color_usage,
                    self.extent,
                    layers,
                )?);
            }
            if let Some(df) = self.depth_format {
                live.depth.push(Chain::new(
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
    blend: xr::EnvironmentBlendMode,
    /// The session's view configuration (stereo, or quad views with the
    /// inset).
    view_type: xr::ViewConfigurationType,
    with_depth: bool,
    last_valid: Vec<Option<TrackedView>>,
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
    let session = live.session.clone().expect("set");
    // --seconds counts from the run's start, across reconnects.
    let started = stats.run_started();
    let mut index = 0u64;
    loop {
        desk_work(live, stats, st, &session, index)?;
        let quit = crate::quit::requested()
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
        one_frame(live, stats, st, index)?;
        index += 1;
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
    if let Some(m) = live.mirror.as_mut() {
        let switched = st.desk.handle(m, index);
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
    let instance = live.instance.clone().expect("set");
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
    let session = live.session.as_ref().expect("set");
    let action = machine.on_state(state);
    match action {
        Action::Begin => {
            let _w = live.watchdog.watch("xrBeginSession");
            session.begin(st.view_type).call("xrBeginSession")?;
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
    let session = live.session.as_ref().expect("set");
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
            st.masks = Some(Arc::new(fetch_masks(session, st.view_type, 2)?));
            stats.visibility_mask_refreshes += 1;
        }
        xr::Event::InteractionProfileChanged(_) => {
            if let Some(c) = &live.controls {
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
        if chains.quad && c.inset.is_some_and(|i| i.composite) {
            return Err(Error::config(
                "--opt inset-composite",
                "this session submits the four views (its view configuration is fixed): inset-composite applies from the next session",
            ));
        }
        let images = chains.images_for(c.aq)?;
        let wide_changed =
            chains.quad && c.inset.map(|i| i.wide_scale) != old.inset.map(|i| i.wide_scale);
        if c.stereo != old.stereo
            || images != chains.extent
            || live.color.is_empty()
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
            live.color.clear();
            live.depth.clear();
            live.inset.clear();
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
    st.chains.extent = st.chains.images_for(config.aq)?;
    st.chains.create(session, live, &config)?;
    let r = Renderer::with_output(ctx, st.scene, &config, nominal, Some(st.chains.output()))?;
    live.driver = Some(FrameDriver::new(r, st.scene)?);
    stats.image_size = [nominal.width, nominal.height];
    Ok(())
}

fn one_frame(live: &mut Live, stats: &mut RunStats, st: &mut LoopState, index: u64) -> Result<()> {
    let session = live.session.clone().expect("set");
    let instance = live.instance.clone().expect("set");
    st.panel_drawn = false;
    // xrWaitFrame: paces the loop to the display.
    let t_wait = Instant::now();
    let fs = {
        let _w = live.watchdog.watch("xrWaitFrame");
        live.waiter
            .as_mut()
            .expect("set")
            .wait()
            .call("xrWaitFrame")?
    };
    let t_cpu = Instant::now();
    // xrBeginFrame.
    {
        let _w = live.watchdog.watch("xrBeginFrame");
        live.stream
            .as_mut()
            .expect("set")
            .begin()
            .call("xrBeginFrame")?;
    }
    let mut rec = app::frame_record(st, index, &fs, t_cpu - t_wait);
    let mut rendered = false;
    let mut layer_views: Option<Vec<xr::View>> = None;
    if fs.should_render {
        // xrLocateViews at the predicted display time.
        if let Some(located) = locate_views(live, st, stats, &session, &fs)? {
            // xrSyncActions: the controllers' poses and buttons.
            let hands = sync_actions(live, &session, &fs)?;
            // The application: interaction, the rig, culling, recording.
            let (rig, pointers) =
                app::update(live, stats, st, &located, hands, &fs, &mut rec, index)?;
            // xrAcquireSwapchainImage, xrWaitSwapchainImage.
            let out = acquire_images(live)?;
            // The application: submit the frame into the images.
            let capture = app::render(live, st, stats, &out, &rig, &rec)?;
            rendered = true;
            // xrReleaseSwapchainImage: the runtime owns them again.
            release_images(live)?;
            app::after_release(live, stats, st, capture, &rig, &pointers)?;
            layer_views = Some(located.views.iter().map(|(_, _, v)| *v).collect());
        }
    }
    // xrEndFrame with the projection layer (and the panel's quad).
    end_frame(
        live,
        &instance,
        &session,
        fs.predicted_display_time,
        layer_views.as_deref(),
        st,
    )?;
    let submitted = layer_views.is_some();
    app::frame_done(
        live,
        stats,
        st,
        rec,
        (rendered, submitted),
        &fs,
        (index, t_cpu),
    )
}

/// xrLocateViews at the frame's predicted display time, invalid views
/// replaced by the last valid ones (None: none valid yet).
fn locate_views(
    live: &Live,
    st: &mut LoopState,
    stats: &mut RunStats,
    session: &xr::Session<xr::Vulkan>,
    fs: &xr::FrameState,
) -> Result<Option<app::Located>> {
    let (flags, views) = {
        let _w = live.watchdog.watch("xrLocateViews");
        session
            .locate_views(
                st.view_type,
                fs.predicted_display_time,
                live.space.as_ref().expect("set"),
            )
            .call("xrLocateViews")?
    };
    let (sane, replaced) = sanitize_views(flags, &views, &mut st.last_valid);
    if replaced {
        stats.invalid_pose_frames += 1;
    }
    Ok(sane.map(|views| {
        let tracking = views.iter().take(2).map(|(p, f, _)| (*p, *f)).collect();
        let focus = match views.get(2..4) {
            Some([l, r]) => Some([l.1, r.1]),
            _ => None,
        };
        app::Located {
            views,
            tracking,
            focus,
        }
    }))
}

/// xrSyncActions and the hands' state at the display time (none without
/// controllers).
fn sync_actions(
    live: &Live,
    session: &xr::Session<xr::Vulkan>,
    fs: &xr::FrameState,
) -> Result<[crate::interact::HandInput; 2]> {
    match &live.controls {
        Some(c) => {
            let _w = live.watchdog.watch("xrSyncActions");
            c.read(
                session,
                live.space.as_ref().expect("set"),
                fs.predicted_display_time,
            )
        }
        None => Ok(Default::default()),
    }
}

/// xrAcquireSwapchainImage and xrWaitSwapchainImage on every swapchain
/// (colour, depth, the insets'): the images the frame goes into.
fn acquire_images(live: &mut Live) -> Result<FrameOutput> {
    let mut images: Vec<(usize, usize)> = Vec::new();
    for (ci, chain) in live
        .color
        .iter_mut()
        .chain(live.depth.iter_mut())
        .chain(live.inset.iter_mut())
        .enumerate()
    {
        let _w = live.watchdog.watch("xrAcquireSwapchainImage");
        let i = chain
            .swapchain
            .acquire_image()
            .call("xrAcquireSwapchainImage")? as usize;
        let _w2 = live.watchdog.watch("xrWaitSwapchainImage");
        chain
            .swapchain
            .wait_image(xr::Duration::INFINITE)
            .call("xrWaitSwapchainImage")?;
        images.push((ci, i));
    }
    let mut out = FrameOutput::default();
    let (ncolor, ndepth) = (live.color.len(), live.depth.len());
    for &(ci, i) in &images {
        if ci < ncolor {
            out.color.push(live.color[ci].images[i]);
        } else if ci < ncolor + ndepth {
            out.depth.push(live.depth[ci - ncolor].images[i]);
        } else {
            out.inset.push(live.inset[ci - ncolor - ndepth].images[i]);
        }
    }
    Ok(out)
}

/// xrReleaseSwapchainImage on every swapchain.
fn release_images(live: &mut Live) -> Result<()> {
    for chain in live
        .color
        .iter_mut()
        .chain(live.depth.iter_mut())
        .chain(live.inset.iter_mut())
    {
        let _w = live.watchdog.watch("xrReleaseSwapchainImage");
        chain
            .swapchain
            .release_image()
            .call("xrReleaseSwapchainImage")?;
    }
    Ok(())
}

/// Eye `eye`'s part of `chains` at `image_rect`: a layer of the one
/// swapchain under multiview (the session's colour chains are one), else
/// the eye's own swapchain.
fn sub_image(
    live: &Live,
    chains: &[Chain],
    eye: usize,
    image_rect: sys::Rect2Di,
) -> sys::SwapchainSubImage {
    let multiview = live.color.len() == 1;
    sys::SwapchainSubImage {
        swapchain: chains[if multiview { 0 } else { eye }].swapchain.as_raw(),
        image_rect,
        image_array_index: if multiview { eye as u32 } else { 0 },
    }
}

/// The eyes' depth for the runtime (with XR_KHR_composition_layer_depth).
/// With the inset the eye's depth exists only inside the inset (the wide
/// view has its own), with lms only in the LMS image's layout: no depth
/// goes to the runtime then.
fn depth_layers(
    live: &Live,
    st: &LoopState,
    views: usize,
    rect: sys::Rect2Di,
) -> Vec<sys::CompositionLayerDepthInfoKHR> {
    let reshaped = live.driver.as_ref().is_some_and(|d| {
        let c = &d.renderer().config;
        c.inset.is_some() || c.lms.is_some()
    });
    if !st.with_depth || reshaped {
        return Vec::new();
    }
    (0..views)
        .map(|eye| sys::CompositionLayerDepthInfoKHR {
            ty: sys::CompositionLayerDepthInfoKHR::TYPE,
            next: std::ptr::null(),
            sub_image: sub_image(live, &live.depth, eye, rect),
            min_depth: 0.0,
            max_depth: 1.0,
            // Reverse-Z with an infinite far plane: depth 0 is at infinity
            // and 1 at the near plane (nearZ > farZ marks reversed depth in
            // XR_KHR_composition_layer_depth).
            near_z: f32::INFINITY,
            far_z: st.args.config.near as f32,
        })
        .collect()
}

/// The projection layer's views, each pointing at its depth (when
/// `depth` has one). Views 2 and 3 are the focus views: their images are
/// the insets, whose FOV is the inset rectangle's (snapped outward to
/// whole pixels around the runtime's).
fn projection_views(
    live: &Live,
    views: &[xr::View],
    depth: &[sys::CompositionLayerDepthInfoKHR],
    (main_rect, inset_rect): (sys::Rect2Di, sys::Rect2Di),
) -> Vec<sys::CompositionLayerProjectionView> {
    let renderer = live.driver.as_ref().map(|d| d.renderer());
    views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let eye = i % 2;
            let (fov, sub) = match (i >= 2, renderer) {
                (true, Some(r)) => {
                    let e = r.extent();
                    let f = crate::view::inset::rect_fov(
                        &crate::xr::fov_of(&views[eye].fov),
                        &r.inset_rect(),
                        e.width,
                        e.height,
                    );
                    (fovf(&f), sub_image(live, &live.inset, eye, inset_rect))
                }
                _ => (v.fov, sub_image(live, &live.color, eye, main_rect)),
            };
            sys::CompositionLayerProjectionView {
                ty: sys::CompositionLayerProjectionView::TYPE,
                next: depth
                    .get(i)
                    .map_or(std::ptr::null(), |d| d as *const _ as *const _),
                pose: v.pose,
                fov,
                sub_image: sub,
            }
        })
        .collect()
}

/// xrEndFrame with one projection layer (and its depth info when the
/// runtime takes depth) and the panel's quad layer when it was drawn this
/// frame, or with no layer when nothing was rendered.
fn end_frame(
    live: &Live,
    instance: &xr::Instance,
    session: &xr::Session<xr::Vulkan>,
    display_time: xr::Time,
    views: Option<&[xr::View]>,
    st: &LoopState,
) -> Result<()> {
    let rect = |e: vk::Extent2D| sys::Rect2Di {
        offset: sys::Offset2Di { x: 0, y: 0 },
        extent: sys::Extent2Di {
            width: e.width as i32,
            height: e.height as i32,
        },
    };
    let renderer = live.driver.as_ref().map(|d| d.renderer());
    // The eyes' images (with quad views the wide views'), and the insets'.
    let main_rect = rect(renderer.map(|r| r.output_extent()).unwrap_or_default());
    let inset_rect = rect(renderer.map(|r| r.inset_extent()).unwrap_or_default());
    let depth_infos = views.map_or_else(Vec::new, |v| depth_layers(live, st, v.len(), main_rect));
    let rects = (main_rect, inset_rect);
    let proj = views.map_or_else(Vec::new, |v| projection_views(live, v, &depth_infos, rects));
    let layer = views.map(|_| sys::CompositionLayerProjection {
        ty: sys::CompositionLayerProjection::TYPE,
        next: std::ptr::null(),
        layer_flags: xr::CompositionLayerFlags::EMPTY,
        space: live.space.as_ref().expect("set").as_raw(),
        view_count: proj.len() as u32,
        views: proj.as_ptr(),
    });
    let quad = match (&layer, st.panel_drawn, &live.panel, &st.interaction.panel) {
        (Some(_), true, Some(xp), Some(p)) => Some(xp.layer(p, live.space.as_ref().expect("set"))),
        _ => None,
    };
    let mut layers: Vec<*const sys::CompositionLayerBaseHeader> = layer
        .iter()
        .map(|l| l as *const sys::CompositionLayerProjection as *const _)
        .collect();
    // The panel over the scene.
    layers.extend(
        quad.iter()
            .map(|q| q as *const sys::CompositionLayerQuad as *const _),
    );
    let info = sys::FrameEndInfo {
        ty: sys::FrameEndInfo::TYPE,
        next: std::ptr::null(),
        display_time,
        environment_blend_mode: st.blend,
        layer_count: layers.len() as u32,
        layers: layers.as_ptr(),
    };
    let _w = live.watchdog.watch("xrEndFrame");
    // SAFETY: every pointer in `info` references locals alive for the call;
    // the swapchain images were released after the frame's submission.
    let r = unsafe { (instance.fp().end_frame)(session.as_raw(), &info) };
    if r.into_raw() < 0 {
        return Err(xr_err("xrEndFrame", r));
    }
    Ok(())
}

/// An OpenXR FOV from a [`Fov`].
fn fovf(f: &Fov) -> sys::Fovf {
    sys::Fovf {
        angle_left: f.left as f32,
        angle_right: f.right as f32,
        angle_up: f.up as f32,
        angle_down: f.down as f32,
    }
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

/// Draws the open panel into its swapchain (made the first time). A panel
/// that cannot be made or drawn is closed for the session with one warning
/// (and `panel.error` in the stats); the menu button then cycles the tools.
fn draw_panel(
    live: &mut Live,
    stats: &mut RunStats,
    st: &mut LoopState,
    pointers: &[Option<crate::interact::panel::PanelHit>; 2],
) -> Result<()> {
    st.panel_drawn = false;
    if st.interaction.panel.is_none() {
        return Ok(());
    }
    let drawn = (|| -> Result<()> {
        if live.panel.is_none() {
            let ctx = live
                .driver
                .as_ref()
                .expect("set")
                .renderer()
                .context()
                .clone();
            let session = live.session.as_ref().expect("set");
            live.panel = Some(super::xr_panel::XrPanel::new(
                &ctx,
                session,
                st.chains.color_format,
            )?);
        }
        let panel = live.panel.as_mut().expect("made above");
        let state = super::panel::PanelState {
            tool: st.interaction.tool,
            config: &st.desk.live.config,
            allowed: &st.desk.live.allowed,
            pointers: pointers.map(|p| p.map(|h| h.uv)),
            times_ms: st.last_times,
            selected: stats.selected.as_ref().map(super::panel::selection_line),
        };
        let frame = panel.ui.frame(&state);
        panel.draw(&frame, &live.watchdog)
    })();
    match drawn {
        Ok(()) => st.panel_drawn = true,
        Err(e) => {
            tracing::warn!("the in-headset panel is off for this session: {e}");
            if let Some(p) = stats.panel.as_mut() {
                p.error = Some(e.to_string());
            }
            st.interaction.panel = None;
            st.interaction.settings.panel = false;
            live.panel = None;
        }
    }
    Ok(())
}
