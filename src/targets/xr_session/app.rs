//! The application's part of an OpenXR frame: what `one_frame` hands over
//! at the points the frame protocol leaves to the application — the
//! interaction and the rig after the views are located and the actions
//! synced, the rendering while the swapchain images are held, the capture
//! and the panel after they are released, and the frame's record after
//! xrEndFrame.

use super::*;

/// The views xrLocateViews gave for the frame, made sane.
pub(super) struct Located {
    /// Each view's pose, field of view and the view as located (the
    /// projection layer's).
    pub views: Vec<TrackedView>,
    /// The eyes (with quad views the context views) in tracking space.
    pub tracking: Vec<(Pose, Fov)>,
    /// With quad views, the focus views' fields of view (they place the
    /// inset).
    pub focus: Option<[Fov; 2]>,
}

/// The record a frame starts with: its timing from xrWaitFrame.
pub(super) fn frame_record(
    st: &LoopState,
    index: u64,
    fs: &xr::FrameState,
    wait: Duration,
) -> FrameRecord {
    FrameRecord {
        index,
        should_render: fs.should_render,
        wait_ms: wait.as_secs_f64() * 1e3,
        predicted_display_time_ns: fs.predicted_display_time.as_nanos(),
        predicted_display_period_ns: fs.predicted_display_period.as_nanos(),
        opt: st.opt.clone(),
        ..FrameRecord::default()
    }
}

/// After xrSyncActions: the interaction's update from the head and hands,
/// the overlay, haptics, events, a kiosk's return to the spawn, then the
/// world rig, which the driver culls and records. Returns the rig and the
/// hands' pointers on the panel.
#[allow(clippy::too_many_arguments)]
pub(super) fn update(
    live: &mut Live,
    stats: &mut RunStats,
    st: &mut LoopState,
    located: &Located,
    hands: [crate::interact::HandInput; 2],
    fs: &xr::FrameState,
    rec: &mut FrameRecord,
    index: u64,
) -> Result<(StereoRig, [Option<crate::interact::panel::PanelHit>; 2])> {
    let args = st.args;
    let session = live.session.clone().expect("set");
    let (tracking, focus) = (&located.tracking, located.focus);
    if let (Some(px), Some(f)) = (st.focus_px.take(), focus) {
        st.pending_resize = focus_density_extent(&st.chains, tracking, &f, px);
    }
    let now_ns = fs.predicted_display_time.as_nanos();
    let dt = st
        .last_display_ns
        .map_or(0.0, |t| (now_ns - t).max(0) as f64 * 1e-9);
    st.last_display_ns = Some(now_ns);
    let input = FrameInput {
        dt,
        head: tracking_head(tracking),
        hands,
    };
    let mut update = st.interaction.update(&input, &st.query);
    panel_input(st, stats, &mut update);
    crate::interact::overlay::build(&st.interaction, &input, &update, &st.query, &mut st.overlay);
    if let Some(c) = &live.controls {
        for hand in (0..2).filter(|&h| update.haptic[h]) {
            let _w = live.watchdog.watch("xrApplyHapticFeedback");
            // A missed tick is no reason to end the session.
            if let Err(e) = c.tick(&session, hand) {
                tracing::warn!(
                    "haptic tick on the {} hand: {e}",
                    crate::interact::HANDS[hand]
                );
            }
        }
    }
    for e in &update.events {
        tracing::info!(
            "interaction: {}",
            serde_json::to_string(e).unwrap_or_default()
        );
    }
    if let Some(picked) = update.events.iter().rev().find_map(|e| match e {
        crate::interact::Event::Select { picked, .. } => Some(picked),
        _ => None,
    }) {
        stats.selected = Some(picked.clone());
    }
    let pointers = update.panel_pointer;
    rec.events = update.events;
    if st.idle.as_mut().is_some_and(|w| w.observe(&input.head, dt)) {
        // Kiosk: nobody has moved for the idle time; the next
        // visitor starts at the spawn.
        st.interaction.viewpoint = 0;
        if let Some(spawn) = st.interaction.viewpoints.first() {
            st.interaction.origin = *spawn;
        }
        tracing::info!(
            "kiosk: back to the spawn after {:.0} s without head motion",
            args.kiosk
                .as_ref()
                .and_then(|k| k.idle_return_s)
                .unwrap_or(0.0)
        );
        rec.events
            .push(crate::interact::Event::Recenter { viewpoint: 0 });
    }
    let mut rig = world_rig(&st.interaction.origin, tracking);
    rec.head_world = Some(PoseFile::from(&rig.head));
    rig.hidden_area = match &st.masks {
        Some(m) => Some(m.clone()),
        None => Some(st.lens_default(&rig)),
    };
    if !st.first_fov_recorded {
        // The eyes', then (quad views) the focus views' as located.
        let located = rig
            .views
            .iter()
            .map(|v| v.fov)
            .chain(focus.iter().flatten().copied());
        for (fov, info) in located.zip(stats.views.iter_mut()) {
            info.fov = Some(fov);
        }
        st.first_fov_recorded = true;
    }
    rec.fov = rig.views.iter().map(|v| v.fov).collect();
    let driver = live.driver.as_mut().expect("set");
    driver.renderer_mut().set_focus(focus);
    driver.set_section(st.interaction.section);
    driver.set_overlay(&st.overlay);
    let shown_ns = fs.predicted_display_time.as_nanos();
    let origin = *st.motion_origin_ns.get_or_insert(shown_ns);
    let time = shown_ns.saturating_sub(origin) as f64 * 1e-9;
    driver.set_time(time);
    driver.set_display_budget(fs.predicted_display_period.as_nanos() as f64 * 1e-6);
    driver.record(&rig, index)?;
    // Rays follow moving instances (from the next frame's input on);
    // only controllers cast them.
    if live.controls.is_some() {
        st.query.move_instances(driver.moved());
    }
    if live.mirror.is_some() {
        st.last_shown = Some((rig.clone(), time));
    }
    Ok((rig, pointers))
}

/// While the swapchain images are held: the frame is submitted into `out`
/// (and read back when this is the frame to capture), and the mirror
/// copies the eyes before the runtime gets the images back. Returns
/// whether this frame is captured.
pub(super) fn render(
    live: &mut Live,
    st: &LoopState,
    stats: &RunStats,
    out: &FrameOutput,
    rig: &StereoRig,
    rec: &FrameRecord,
) -> Result<bool> {
    let args = st.args;
    let driver = live.driver.as_mut().expect("set");
    let capture = args.capture.is_some() && args.frames == Some(stats.frames_submitted + 1);
    driver.submit(Some(out), capture)?;
    if let Some(m) = live.mirror.as_mut() {
        // Before the release: the runtime owns the images after it.
        let eyes: Vec<Source> = (0..2)
            .map(|eye| {
                let (image, layer) = if out.color.len() == 1 {
                    (out.color[0], eye as u32)
                } else {
                    (out.color[eye], 0)
                };
                Source {
                    image,
                    layer,
                    // The part rendered (smaller with aq; with
                    // quad views the wide view).
                    extent: driver.renderer().output_extent(),
                }
            })
            .collect();
        m.copy(
            &eyes,
            rig.hidden_area.as_deref().map(Vec::as_slice),
            &rec.fov,
        )?;
    }
    Ok(capture)
}

/// After the images are released: the capture's files (when this frame is
/// captured) and the in-headset panel.
pub(super) fn after_release(
    live: &mut Live,
    stats: &mut RunStats,
    st: &mut LoopState,
    capture: bool,
    rig: &StereoRig,
    pointers: &[Option<crate::interact::panel::PanelHit>; 2],
) -> Result<()> {
    let args = st.args;
    let driver = live.driver.as_mut().expect("set");
    if capture {
        let dir = args.capture.as_deref().expect("checked");
        if st.chains.quad {
            // The four views as submitted: the wide views as the
            // eyes, the insets beside them.
            let [wl, wr, il, ir] = driver.renderer_mut().read_quad_images()?;
            write_capture(dir, &[wl, wr], rig)?;
            let png = |img: &image::RgbaImage, side: &str| {
                crate::targets::headless::save_png(img, &dir.join(format!("inset-{side}.png")))
            };
            png(&il, "left")?;
            png(&ir, "right")?;
        } else {
            let imgs = driver.read_images()?;
            write_capture(dir, &imgs, rig)?;
        }
    }
    draw_panel(live, stats, st, pointers)
}

/// After xrEndFrame: the frame's layers and counts, the mirror's present,
/// the finished frames' records, the overlay text and the warm-up memory
/// sample. `submitted`: a projection layer went into xrEndFrame.
#[allow(clippy::too_many_arguments)]
pub(super) fn frame_done(
    live: &mut Live,
    stats: &mut RunStats,
    st: &mut LoopState,
    mut rec: FrameRecord,
    (rendered, submitted): (bool, bool),
    fs: &xr::FrameState,
    (index, t_cpu): (u64, Instant),
) -> Result<()> {
    rec.layers = if submitted {
        1 + u32::from(st.panel_drawn)
    } else {
        0
    };
    if submitted && st.panel_drawn {
        if let Some(p) = stats.panel.as_mut() {
            p.frames_shown += 1;
        }
    }
    if submitted {
        stats.frames_submitted += 1;
        stats.frames_rendered += 1;
        // After the frame is submitted: the window never holds it up.
        if let Some(m) = live.mirror.as_mut() {
            m.present()?;
        }
    }
    // The CPU time still holds the wait for a frame slot; the record is
    // completed (GPU time, counts, that wait taken out) when its frame
    // finishes, and written in frame order.
    rec.cpu_ms = t_cpu.elapsed().as_secs_f64() * 1e3;
    st.records.push(rec, rendered);
    let driver = live.driver.as_mut().expect("set");
    while let Some(r) = driver.take_completed() {
        let period_ms = fs.predicted_display_period.as_nanos() as f64 * 1e-6;
        st.last_times = Some((r.gpu_ms(), r.cpu_ms(), period_ms));
        if let Some(m) = live.mirror.as_mut() {
            m.push_frame(&r);
        }
        st.records.complete(&r, stats);
    }
    // The overlay shows the records' own times: one set of figures.
    let mirror = &mut live.mirror;
    st.records.flush(stats, |i, t| {
        if let Some(m) = mirror.as_mut() {
            m.push_record(i, t);
        }
    })?;
    if let Some(m) = live.mirror.as_mut() {
        let period_ms = fs.predicted_display_period.as_nanos() as f64 * 1e-6;
        m.set_overlay_text(
            &st.opt,
            if period_ms > 0.0 {
                period_ms
            } else {
                1000.0 / 90.0
            },
        );
    }
    if index + 1 == crate::targets::session::WARMUP_FRAMES {
        if let Some(d) = &live.driver {
            stats.sample_memory(d.renderer().context(), false);
        }
    }
    Ok(())
}
