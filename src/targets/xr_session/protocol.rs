//! The OpenXR frame protocol (OpenXR 1.0 §10.4), in spec order: wait,
//! begin, locate the views, sync the actions, acquire and wait the
//! swapchain images, release them, end the frame. What an application does
//! between those calls is behind [`FrameApp`], as in openxrs'
//! `examples/vulkan.rs`, whose loop calls into its renderer at the same
//! points.

use super::*;

/// The application's work at the points an OpenXR frame leaves to it.
/// [`one_frame`] calls it in this order, once per frame.
pub(super) trait FrameApp {
    /// After xrBeginFrame: the frame's record, from its timing (`wait`:
    /// how long xrWaitFrame blocked).
    fn begin(&mut self, index: u64, fs: &xr::FrameState, wait: Duration) -> FrameRecord;

    /// xrLocateViews gave at least one invalid view this frame: the last
    /// valid ones stand in.
    fn views_replaced(&mut self);

    /// After xrLocateViews and xrSyncActions: the interaction, the world
    /// rig, culling and recording (the session is there for haptics and
    /// the panel's swapchain).
    fn update(
        &mut self,
        rt: &Runtime,
        located: &app::Located,
        hands: [crate::interact::HandInput; 2],
        frame: (&xr::FrameState, u64),
        rec: &mut FrameRecord,
    ) -> Result<app::Prepared>;

    /// While the swapchain images are held: the frame submitted into
    /// `out`. Returns whether this frame is captured.
    fn render(&mut self, out: &FrameOutput, p: &app::Prepared, rec: &FrameRecord) -> Result<bool>;

    /// After xrReleaseSwapchainImage: work on the released frame (a
    /// capture, the panel).
    fn after_release(&mut self, rt: &Runtime, capture: bool, p: &app::Prepared) -> Result<()>;

    /// What xrEndFrame submits besides the located views.
    fn layers(&self) -> app::Layers<'_>;

    /// After xrEndFrame: the frame's record and everything shown after
    /// the frame went out. `flags`: a frame was rendered, a projection
    /// layer was submitted.
    fn frame_done(
        &mut self,
        rec: FrameRecord,
        flags: (bool, bool),
        fs: &xr::FrameState,
        timing: (u64, Instant),
    ) -> Result<()>;
}

/// One frame of the protocol, the application's work at its points.
pub(super) fn one_frame(
    rt: &mut Runtime,
    watchdog: &Watchdog,
    app: &mut impl FrameApp,
    index: u64,
) -> Result<()> {
    // xrWaitFrame: paces the loop to the display.
    let t_wait = Instant::now();
    let fs = {
        let _w = watchdog.watch("xrWaitFrame");
        let waiter = rt.waiter.as_mut().expect("set");
        waiter.wait().call("xrWaitFrame")?
    };
    let t_cpu = Instant::now();
    {
        let _w = watchdog.watch("xrBeginFrame");
        let stream = rt.stream.as_mut().expect("set");
        stream.begin().call("xrBeginFrame")?;
    }
    let mut rec = app.begin(index, &fs, t_cpu - t_wait);
    let mut rendered = false;
    let mut layer_views: Option<Vec<xr::View>> = None;
    if fs.should_render {
        // xrLocateViews at the predicted display time.
        let (located, replaced) = locate_views(rt, watchdog, &fs)?;
        if replaced {
            app.views_replaced();
        }
        if let Some(located) = located {
            // xrSyncActions: the controllers' poses and buttons.
            let hands = sync_actions(rt, watchdog, &fs)?;
            let prepared = app.update(rt, &located, hands, (&fs, index), &mut rec)?;
            // xrAcquireSwapchainImage, xrWaitSwapchainImage.
            let out = acquire_images(rt, watchdog)?;
            let capture = app.render(&out, &prepared, &rec)?;
            rendered = true;
            // xrReleaseSwapchainImage: the runtime owns them again.
            release_images(rt, watchdog)?;
            app.after_release(rt, capture, &prepared)?;
            layer_views = Some(located.views.iter().map(|(_, _, v)| *v).collect());
        }
    }
    // xrEndFrame with the projection layer (and the application's quad).
    let views = layer_views.as_deref();
    end_frame(
        rt,
        watchdog,
        fs.predicted_display_time,
        views,
        &app.layers(),
    )?;
    let submitted = layer_views.is_some();
    app.frame_done(rec, (rendered, submitted), &fs, (index, t_cpu))
}

/// xrLocateViews at the frame's predicted display time, invalid views
/// replaced by the last valid ones (None: none valid yet), and whether any
/// was replaced.
fn locate_views(
    rt: &mut Runtime,
    watchdog: &Watchdog,
    fs: &xr::FrameState,
) -> Result<(Option<app::Located>, bool)> {
    let session = rt.session.as_ref().expect("set");
    let (flags, views) = {
        let _w = watchdog.watch("xrLocateViews");
        let space = rt.space.as_ref().expect("set");
        session
            .locate_views(rt.view_type, fs.predicted_display_time, space)
            .call("xrLocateViews")?
    };
    let (sane, replaced) = sanitize_views(flags, &views, &mut rt.last_valid);
    let located = sane.map(|views| {
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
    });
    Ok((located, replaced))
}

/// xrSyncActions and the hands' state at the display time (none without
/// controllers).
fn sync_actions(
    rt: &Runtime,
    watchdog: &Watchdog,
    fs: &xr::FrameState,
) -> Result<[crate::interact::HandInput; 2]> {
    match &rt.controls {
        Some(c) => {
            let _w = watchdog.watch("xrSyncActions");
            let session = rt.session.as_ref().expect("set");
            let space = rt.space.as_ref().expect("set");
            c.read(session, space, fs.predicted_display_time)
        }
        None => Ok(Default::default()),
    }
}

/// xrAcquireSwapchainImage and xrWaitSwapchainImage on every swapchain
/// (colour, depth, the insets'): the images the frame goes into.
fn acquire_images(rt: &mut Runtime, watchdog: &Watchdog) -> Result<FrameOutput> {
    let mut out = FrameOutput::default();
    let lists = [
        (&mut rt.color, &mut out.color),
        (&mut rt.depth, &mut out.depth),
        (&mut rt.inset, &mut out.inset),
    ];
    for (chains, images) in lists {
        for chain in chains.iter_mut() {
            let _w = watchdog.watch("xrAcquireSwapchainImage");
            let i = chain
                .swapchain
                .acquire_image()
                .call("xrAcquireSwapchainImage")? as usize;
            let _w2 = watchdog.watch("xrWaitSwapchainImage");
            chain
                .swapchain
                .wait_image(xr::Duration::INFINITE)
                .call("xrWaitSwapchainImage")?;
            images.push(chain.images[i]);
        }
    }
    Ok(out)
}

/// xrReleaseSwapchainImage on every swapchain.
fn release_images(rt: &mut Runtime, watchdog: &Watchdog) -> Result<()> {
    let chains = rt.color.iter_mut().chain(rt.depth.iter_mut());
    for chain in chains.chain(rt.inset.iter_mut()) {
        let _w = watchdog.watch("xrReleaseSwapchainImage");
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
    rt: &Runtime,
    chains: &[Chain],
    eye: usize,
    image_rect: sys::Rect2Di,
) -> sys::SwapchainSubImage {
    let multiview = rt.color.len() == 1;
    sys::SwapchainSubImage {
        swapchain: chains[if multiview { 0 } else { eye }].swapchain.as_raw(),
        image_rect,
        image_array_index: if multiview { eye as u32 } else { 0 },
    }
}

/// The eyes' depth for the runtime (with XR_KHR_composition_layer_depth),
/// when the application's frame has a plain depth image per eye.
fn depth_layers(
    rt: &Runtime,
    layers: &app::Layers,
    views: usize,
    rect: sys::Rect2Di,
) -> Vec<sys::CompositionLayerDepthInfoKHR> {
    let Some(near) = layers.depth_near.filter(|_| rt.with_depth) else {
        return Vec::new();
    };
    (0..views)
        .map(|eye| sys::CompositionLayerDepthInfoKHR {
            ty: sys::CompositionLayerDepthInfoKHR::TYPE,
            next: std::ptr::null(),
            sub_image: sub_image(rt, &rt.depth, eye, rect),
            min_depth: 0.0,
            max_depth: 1.0,
            // Reverse-Z with an infinite far plane: depth 0 is at infinity
            // and 1 at the near plane (nearZ > farZ marks reversed depth in
            // XR_KHR_composition_layer_depth).
            near_z: f32::INFINITY,
            far_z: near,
        })
        .collect()
}

/// The projection layer's views, each pointing at its depth (when
/// `depth` has one). Views 2 and 3 are the focus views: their images are
/// the insets, whose FOV is the inset rectangle's (snapped outward to
/// whole pixels around the runtime's).
fn projection_views(
    rt: &Runtime,
    views: &[xr::View],
    depth: &[sys::CompositionLayerDepthInfoKHR],
    layers: &app::Layers,
) -> Vec<sys::CompositionLayerProjectionView> {
    let (main_rect, inset_rect) = (rect(layers.main), rect(layers.inset));
    views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let eye = i % 2;
            let (fov, sub) = match (i >= 2, &layers.inset_place) {
                (true, Some((extent, place))) => {
                    let f = crate::view::inset::rect_fov(
                        &crate::xr::fov_of(&views[eye].fov),
                        place,
                        extent.width,
                        extent.height,
                    );
                    (fovf(&f), sub_image(rt, &rt.inset, eye, inset_rect))
                }
                _ => (v.fov, sub_image(rt, &rt.color, eye, main_rect)),
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

/// The image rectangle of size `e` at the origin.
fn rect(e: vk::Extent2D) -> sys::Rect2Di {
    sys::Rect2Di {
        offset: sys::Offset2Di { x: 0, y: 0 },
        extent: sys::Extent2Di {
            width: e.width as i32,
            height: e.height as i32,
        },
    }
}

/// xrEndFrame with one projection layer (and its depth info when the
/// runtime takes depth) and the application's quad over it, or with no
/// layer when nothing was rendered.
fn end_frame(
    rt: &Runtime,
    watchdog: &Watchdog,
    display_time: xr::Time,
    views: Option<&[xr::View]>,
    layers: &app::Layers,
) -> Result<()> {
    let space = rt.space.as_ref().expect("set");
    let depth_infos = views.map_or_else(Vec::new, |v| {
        depth_layers(rt, layers, v.len(), rect(layers.main))
    });
    let proj = views.map_or_else(Vec::new, |v| projection_views(rt, v, &depth_infos, layers));
    let layer = views.map(|_| sys::CompositionLayerProjection {
        ty: sys::CompositionLayerProjection::TYPE,
        next: std::ptr::null(),
        layer_flags: xr::CompositionLayerFlags::EMPTY,
        space: space.as_raw(),
        view_count: proj.len() as u32,
        views: proj.as_ptr(),
    });
    let quad = match (&layer, &layers.panel) {
        (Some(_), Some((xp, p))) => Some(xp.layer(p, space)),
        _ => None,
    };
    let mut list: Vec<*const sys::CompositionLayerBaseHeader> = layer
        .iter()
        .map(|l| l as *const sys::CompositionLayerProjection as *const _)
        .collect();
    // The panel over the scene.
    list.extend(
        quad.iter()
            .map(|q| q as *const sys::CompositionLayerQuad as *const _),
    );
    let info = sys::FrameEndInfo {
        ty: sys::FrameEndInfo::TYPE,
        next: std::ptr::null(),
        display_time,
        environment_blend_mode: rt.blend,
        layer_count: list.len() as u32,
        layers: list.as_ptr(),
    };
    let instance = rt.instance.as_ref().expect("set");
    let session = rt.session.as_ref().expect("set");
    let _w = watchdog.watch("xrEndFrame");
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
