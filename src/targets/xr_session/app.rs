//! The application's part of an OpenXR frame: vergence's [`FrameApp`],
//! what `one_frame` hands over at the points the frame protocol leaves to
//! the application — the
//! interaction and the rig after the views are located and the actions
//! synced, the rendering while the swapchain images are held, the capture
//! and the panel after they are released, and the frame's record after
//! xrEndFrame.

use super::protocol::FrameApp;
use super::*;

/// vergence's side of a session's frames: the mirror, the panel and the
/// renderer of the session ([`Live`]'s), with the loop's state and the
/// run's statistics.
pub(super) struct SessionApp<'a, 's> {
    pub mirror: &'a mut Option<Mirror>,
    pub panel: &'a mut Option<super::super::xr_panel::XrPanel>,
    pub driver: &'a mut Option<FrameDriver>,
    pub watchdog: &'a Watchdog,
    pub stats: &'a mut RunStats,
    pub st: &'a mut LoopState<'s>,
}

/// What the update hands on to the rendering and after it: the world rig
/// and the hands' pointers on the panel.
pub(super) struct Prepared {
    rig: StereoRig,
    pointers: [Option<crate::interact::panel::PanelHit>; 2],
}

/// What xrEndFrame submits besides the located views.
pub(super) struct Layers<'a> {
    /// The size rendered into the colour images (with quad views the
    /// wide views').
    pub main: vk::Extent2D,
    /// The insets' size (quad views).
    pub inset: vk::Extent2D,
    /// With quad views: the eye size and the inset rectangle, which give
    /// the focus views' FOV.
    pub inset_place: Option<(vk::Extent2D, crate::view::inset::PixelRect)>,
    /// The near plane, when the frame's depth is a plain depth image per
    /// eye the runtime may take (not with the inset or lms).
    pub depth_near: Option<f32>,
    /// The panel's quad, when it was drawn this frame.
    pub panel: Option<(
        &'a super::super::xr_panel::XrPanel,
        &'a crate::interact::panel::Panel,
    )>,
}

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

impl FrameApp for SessionApp<'_, '_> {
    /// The record a frame starts with: its timing from xrWaitFrame.
    fn begin(&mut self, index: u64, fs: &xr::FrameState, wait: Duration) -> FrameRecord {
        let st = &self.st;
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

    fn views_replaced(&mut self) {
        self.stats.invalid_pose_frames += 1;
    }

    /// After xrSyncActions: the interaction's update from the head and
    /// hands, then the world rig, which the driver culls and records.
    fn update(
        &mut self,
        rt: &Runtime,
        located: &Located,
        hands: [crate::interact::HandInput; 2],
        (fs, index): (&xr::FrameState, u64),
        rec: &mut FrameRecord,
    ) -> Result<Prepared> {
        let pointers = self.interact(rt, located, hands, fs, rec);
        let rig = self.record_rig(rt, located, (fs, index), rec)?;
        Ok(Prepared { rig, pointers })
    }

    /// While the swapchain images are held: the frame is submitted into `out`
    /// (and read back when this is the frame to capture), and the mirror
    /// copies the eyes before the runtime gets the images back. Returns
    /// whether this frame is captured.
    fn render(&mut self, out: &FrameOutput, p: &Prepared, rec: &FrameRecord) -> Result<bool> {
        let SessionApp {
            mirror,
            driver,
            stats,
            st,
            ..
        } = self;
        let rig = &p.rig;
        let args = st.args;
        let driver = driver.as_mut().expect("set");
        // The last frame: frame N of --frames N, else the first frame
        // after a rehearsal played out.
        let last = match args.frames {
            Some(n) => n == stats.frames_submitted + 1,
            None => !st.captured && st.rehearsal.as_ref().is_some_and(|p| p.finished()),
        };
        let capture = args.capture.is_some() && last;
        st.captured |= capture;
        driver.submit(Some(out), capture)?;
        if let Some(m) = mirror.as_mut() {
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
    fn after_release(&mut self, rt: &Runtime, capture: bool, p: &Prepared) -> Result<()> {
        let (st, args, rig) = (&*self.st, self.st.args, &p.rig);
        let driver = self.driver.as_mut().expect("set");
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
        self.draw_panel(rt, &p.pointers);
        Ok(())
    }

    fn layers(&self) -> Layers<'_> {
        let renderer = self.driver.as_ref().map(|d| d.renderer());
        let flat = renderer
            .is_none_or(|r| r.config.effort.inset.is_none() && r.config.effort.lms.is_none());
        let panel = match (
            self.st.panel_drawn,
            self.panel.as_ref(),
            &self.st.interaction.panel,
        ) {
            (true, Some(xp), Some(p)) => Some((xp, p)),
            _ => None,
        };
        Layers {
            main: renderer.map(|r| r.output_extent()).unwrap_or_default(),
            inset: renderer.map(|r| r.inset_extent()).unwrap_or_default(),
            inset_place: renderer.map(|r| (r.extent(), r.inset_rect())),
            depth_near: flat.then_some(self.st.args.config.frame.near as f32),
            panel,
        }
    }

    /// After xrEndFrame: the frame's layers and counts, the mirror's present,
    /// the finished frames' records, the overlay text and the warm-up memory
    /// sample. `submitted`: a projection layer went into xrEndFrame.
    fn frame_done(
        &mut self,
        mut rec: FrameRecord,
        (rendered, submitted): (bool, bool),
        fs: &xr::FrameState,
        (index, t_cpu): (u64, Instant),
    ) -> Result<()> {
        let SessionApp {
            mirror,
            driver,
            stats,
            st,
            ..
        } = self;
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
            if let Some(m) = mirror.as_mut() {
                m.present()?;
            }
        }
        // The CPU time still holds the wait for a frame slot; the record is
        // completed (GPU time, counts, that wait taken out) when its frame
        // finishes, and written in frame order.
        rec.cpu_ms = t_cpu.elapsed().as_secs_f64() * 1e3;
        st.records.push(rec, rendered);
        let driver = driver.as_mut().expect("set");
        while let Some(r) = driver.take_completed() {
            let period_ms = fs.predicted_display_period.as_nanos() as f64 * 1e-6;
            st.last_times = Some((r.gpu_ms(), r.cpu_ms(), period_ms));
            if let Some(m) = mirror.as_mut() {
                m.push_frame(&r);
            }
            st.records.complete(&r, stats);
        }
        // The overlay shows the records' own times: one set of figures.
        st.records.flush(stats, |i, t| {
            if let Some(m) = mirror.as_mut() {
                m.push_record(i, t);
            }
        })?;
        if let Some(m) = mirror.as_mut() {
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
            stats.sample_memory(driver.renderer().context(), false);
        }
        Ok(())
    }
}

impl SessionApp<'_, '_> {
    /// The interaction's update from the head and hands: the overlay,
    /// haptics, events, the selection and a kiosk's return to the spawn.
    /// Returns the hands' pointers on the panel.
    fn interact(
        &mut self,
        rt: &Runtime,
        located: &Located,
        hands: [crate::interact::HandInput; 2],
        fs: &xr::FrameState,
        rec: &mut FrameRecord,
    ) -> [Option<crate::interact::panel::PanelHit>; 2] {
        let SessionApp {
            watchdog,
            stats,
            st,
            ..
        } = self;
        let args = st.args;
        let session = rt.session.as_ref().expect("set");
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
        crate::interact::overlay::build(
            &st.interaction,
            &input,
            &update,
            &st.query,
            &mut st.overlay,
        );
        if let Some(c) = &rt.controls {
            for hand in (0..2).filter(|&h| update.haptic[h]) {
                let _w = watchdog.watch("xrApplyHapticFeedback");
                // A missed tick is no reason to end the session.
                if let Err(e) = c.tick(session, hand) {
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
        pointers
    }

    /// The world rig from the tracking origin and the located views, its
    /// hidden area, and the frame recorded for it.
    fn record_rig(
        &mut self,
        rt: &Runtime,
        located: &Located,
        (fs, index): (&xr::FrameState, u64),
        rec: &mut FrameRecord,
    ) -> Result<StereoRig> {
        let SessionApp {
            mirror,
            driver,
            stats,
            st,
            ..
        } = self;
        let (tracking, focus) = (&located.tracking, located.focus);
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
        let driver = driver.as_mut().expect("set");
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
        if rt.controls.is_some() {
            st.query.move_instances(driver.moved());
        }
        if mirror.is_some() {
            st.last_shown = Some((rig.clone(), time));
        }
        Ok(rig)
    }

    /// Draws the open panel into its swapchain (made the first time). A
    /// panel that cannot be made or drawn is closed for the session with
    /// one warning (and `panel.error` in the stats); the menu button then
    /// cycles the tools.
    fn draw_panel(
        &mut self,
        rt: &Runtime,
        pointers: &[Option<crate::interact::panel::PanelHit>; 2],
    ) {
        let SessionApp {
            panel,
            driver,
            watchdog,
            stats,
            st,
            ..
        } = self;
        st.panel_drawn = false;
        if st.interaction.panel.is_none() {
            return;
        }
        let drawn = (|| -> Result<()> {
            if panel.is_none() {
                let ctx = driver.as_ref().expect("set").renderer().context().clone();
                let session = rt.session.as_ref().expect("set");
                **panel = Some(super::super::xr_panel::XrPanel::new(
                    &ctx,
                    session,
                    st.chains.color_format,
                )?);
            }
            let xp = panel.as_mut().expect("made above");
            let state = super::super::panel::PanelState {
                tool: st.interaction.tool,
                config: &st.desk.live.config,
                allowed: &st.desk.live.allowed,
                pointers: pointers.map(|p| p.map(|h| h.uv)),
                times_ms: st.last_times,
                selected: stats
                    .selected
                    .as_ref()
                    .map(super::super::panel::selection_line),
            };
            let frame = xp.ui.frame(&state);
            xp.draw(&frame, watchdog)
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
                **panel = None;
            }
        }
    }
}
