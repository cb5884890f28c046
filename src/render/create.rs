//! Creating a `Renderer`: the targets, descriptors, per-slot buffers and
//! queries, the passes the configuration asks for, and the output copy.

use super::*;

impl Renderer {
    /// Creates a renderer for `scene` at `extent` pixels per eye.
    pub fn new(
        ctx: Arc<Context>,
        scene: &Scene,
        config: &RenderConfig,
        extent: vk::Extent2D,
    ) -> Result<Renderer> {
        Renderer::with_output(ctx, scene, config, extent, None)
    }

    /// Creates a renderer whose frames are also copied into images of
    /// `output` (see [`Renderer::submit_frame`]).
    pub fn with_output(
        ctx: Arc<Context>,
        scene: &Scene,
        config: &RenderConfig,
        extent: vk::Extent2D,
        output: Option<OutputSpec>,
    ) -> Result<Renderer> {
        check_request(config, extent, output.as_ref())?;
        let samples = config.frame.msaa.min(ctx.caps.max_samples);
        let slots = config.submission.frames_in_flight as usize;
        // With aq every target is made once for the largest scale.
        let nominal = extent;
        let allocated = if config.effort.aq {
            scaled(extent, crate::adaptive::MAX_SCALE)
        } else {
            extent
        };
        let extent = allocated;
        let (scene_gpu, draw_records, descriptors, lod_report) =
            upload_scene(&ctx, scene, config, slots)?;
        let depth_out = output.as_ref().is_some_and(|o| o.depth);
        let mask_in_depth = mask_in_depth(config, depth_out);
        let stencil = tests_stencil(config, mask_in_depth) || depth_out;
        let depth_format = match ctx.caps.depth_only_format {
            Some(f) if !stencil => f,
            _ => ctx.caps.depth_format,
        };
        let quad = output.is_some_and(|o| o.quad);
        let inset_choice = inset_choice(config, ctx.caps.max_multiview_views, samples, quad);
        let mut r = Renderer {
            ctx: ctx.clone(),
            depth_format,
            config: with_samples(config, samples),
            extent: nominal,
            nominal,
            allocated,
            inset_rect: crate::view::inset::PixelRect {
                x0: 0,
                y0: 0,
                x1: nominal.width,
                y1: nominal.height,
            },
            focus: None,
            quad,
            vertices: VertexBindings::new(&scene_gpu),
            scene: Some(scene_gpu),
            targets: None,
            descriptors,
            per_slot: Vec::with_capacity(slots),
            ring: None,
            slot: 0,
            slots,
            completed: VecDeque::with_capacity(slots + 1),
            slot_wait_ms: 0.0,
            batcher: Batcher::new(scene),
            blended: None,
            sun: scene.sun,
            extras: uniforms::FrameExtras {
                section: config.frame.section.map(culling::plane_of),
                overlay: Vec::new(),
            },
            batches: Batches::default(),
            pending: None,
            shading_rate: None,
            passes: Passes::default(),
            output: output.map(OutputCopy::new),
            readback: Readback::new(),
            frame_index: 0,
            mffr_fallbacks: 0,
            mffr_partition: !config.effort.mffr.is_some_and(|m| m.no_split),
            foveation_path: "off".into(),
            four_view: inset_choice.as_ref().is_some_and(|c| c.0),
            inset_path: inset_choice.map(|c| c.1),
            mask_in_depth,
            wide_region: crate::view::inset::PixelRect::default(),
            lod: lod_report,
            draw_records,
            parallel: None,
            updates: instance_updates::InstanceUpdates::new(slots),
            instance_count: scene.instances.len(),
        };
        // Made into the renderer, so a failure from here on drops it and
        // with it everything made so far.
        r.make_slots(config, slots)?;
        r.make_passes(scene, config, extent, slots)?;
        r.make_targets(config, extent, samples, depth_format, output)?;
        r.make_culling(scene, config, samples, slots)?;
        Ok(r)
    }

    /// Per frame slot its uniform buffer and queries; the frame ring; the
    /// recording threads.
    fn make_slots(&mut self, config: &RenderConfig, slots: usize) -> Result<()> {
        let ctx = self.ctx.clone();
        let r = self;
        for i in 0..slots {
            let ubo = Buffer::new(
                &ctx,
                &BufferDesc {
                    name: &format!("frame data {i}"),
                    size: UBO_SIZE,
                    usage: vk::BufferUsageFlags::UNIFORM_BUFFER,
                    location: MemoryLocation::CpuToGpu,
                    category: "per-frame",
                },
            )?;
            // Secondary command buffers may run inside the frame's
            // statistics query only with inheritedQueries.
            let stats = config.submission.record_threads.is_none() || ctx.caps.inherited_queries;
            let queries = Queries::new(&ctx, 32, stats);
            // The buffer joins the renderer before the queries' result is
            // looked at, so a failure drops (and destroys) it with the rest.
            r.per_slot.push(Slot {
                ubo,
                visible: None,
                queries: None,
                in_flight: None,
            });
            r.per_slot[i].queries = Some(queries?);
        }
        r.ring = Some(FrameRing::new(&ctx, slots)?);
        if let Some(n) = config.submission.record_threads {
            r.parallel = Some(ParallelRecording::new(&ctx, n as usize, slots)?);
        }
        Ok(())
    }

    /// The foveation pattern, the passes the configuration asks for and
    /// the point cloud's.
    fn make_passes(
        &mut self,
        scene: &Scene,
        config: &RenderConfig,
        extent: vk::Extent2D,
        slots: usize,
    ) -> Result<()> {
        let ctx = self.ctx.clone();
        let r = self;
        // Pipelines depend on the shading-rate attachment: foveation first.
        let (rates, path) = ShadingRate::new(&ctx, &r.config, extent)?;
        if rates.is_none() {
            r.config.effort.foveation = Level::Off;
        }
        r.shading_rate = rates;
        r.foveation_path = path;
        match (&r.inset_path, config.effort.inset) {
            (Some(path), Some(i)) if i.four_views && !r.four_view => {
                tracing::warn!("inset-views=4 falls back: {path}")
            }
            (Some(path), _) => tracing::info!("inset: {path}"),
            _ => {}
        }
        let ubos = r.ubos();
        let points = scene
            .points
            .as_deref()
            .map(|cloud| (cloud, ubos.as_slice()));
        r.passes = Passes::new(&r.pipeline_setup(), config, (extent, slots), points)?;
        Ok(())
    }

    /// The frame's attachments (and the inset composite's binding to them).
    fn make_targets(
        &mut self,
        config: &RenderConfig,
        extent: vk::Extent2D,
        samples: u32,
        depth_format: vk::Format,
        output: Option<OutputSpec>,
    ) -> Result<()> {
        let ctx = self.ctx.clone();
        let r = self;
        r.targets = Some(Attachments::new(
            &ctx,
            extent,
            samples,
            config.frame.stereo == StereoMode::Multiview,
            SetOptions {
                depth_format,
                // The depth variants of the timewarp read the frame's depth;
                // the rotation-only one does not.
                keep_depth: output.is_some_and(|o| o.depth)
                    || config
                        .simulator
                        .timewarp
                        .is_some_and(|t| t.variant != crate::config::TimewarpVariant::Rotation),
                // With a quad output the runtime composites the inset: no
                // composed image.
                composed: (config.effort.rdm.is_some() && config.effort.rdm_fill)
                    || (config.effort.inset.is_some() && !r.quad)
                    || config.effort.lms.is_some(),
                sampled: false,
                storage_output: config.effort.inset.is_some() && !r.quad,
                storage_resolve: false,
                occlusion: config.culling.occlusion,
                multiview_layers: if r.four_view { 4 } else { 2 },
                one_sample_depth: false,
            },
        )?);
        if let (Some(inset), Some(targets), false) =
            (r.passes.inset.as_mut(), r.targets.as_ref(), r.quad)
        {
            inset.bind(&ctx, targets)?;
        }
        Ok(())
    }

    /// The GPU cull (with the blended instances' CPU side) or the CPU
    /// path's visible lists.
    fn make_culling(
        &mut self,
        scene: &Scene,
        config: &RenderConfig,
        samples: u32,
        slots: usize,
    ) -> Result<()> {
        let r = self;
        if config.culling.gpu_cull {
            let order = r.batcher.order().to_vec();
            r.blended = blended::GpuBlended::new(config, scene, &r.batcher)?;
            if r.blended.is_some() && config.effort.mffr.is_some() {
                return Err(Error::config(
                    "--opt",
                    format!(
                        "scene '{}' has blended primitives, which gpu-cull draws after the near field's opaque ones; with mffr they would be cut at the far field's split: leave out mffr or gpu-cull",
                        scene.name
                    ),
                ));
            }
            let occlusion = config
                .culling
                .occlusion
                .then(|| r.occlusion_targets(samples));
            // With occlusion the inset scope draws the same two sets as the
            // wide one (early, late), with mffr the same near set: no lists
            // of its own.
            let inset_lists = config.effort.inset.is_some()
                && !r.four_view
                && !config.culling.occlusion
                && config.effort.mffr.is_none();
            let gpu = GpuCull::new(
                &r.pipeline_setup(),
                scene,
                &order,
                &r.ubos(),
                occlusion,
                config.culling.lod.is_some(),
                (config.effort.mffr.is_some(), inset_lists),
                r.blended.as_ref().map_or(0, |b| b.capacity()),
            )?;
            r.passes.gpu_cull = Some(gpu);
        }
        // The list holds an id per (visible instance, primitive), and with
        // the inset its own list after that (`Batches::inset_start`): room
        // for an id per instance in each list, so that with one primitive
        // per mesh the first frames do not grow it (more primitives grow it
        // once, to what is visible: sizing for every primitive of every
        // instance would reserve far more than a view sees on large scenes).
        let lists = if config.effort.inset.is_some() { 2 } else { 1 };
        let ids = scene.instances.len().max(1) * lists;
        for i in 0..slots {
            if r.passes.gpu_cull.is_some() {
                r.write_descriptors(i);
            } else {
                r.ensure_visible_capacity(i, ids)?;
            }
        }
        Ok(())
    }

    /// The views occlusion's depth pyramid reduces: with the inset (two
    /// scopes) its wide views, which cover each eye's whole field of view
    /// with the eye's projection (the inset scope covers only its
    /// rectangle); else the eyes' targets (`samples` per pixel).
    fn occlusion_targets(&self, samples: u32) -> passes::gpu_cull::OcclusionTargets<'_> {
        let near = self.config.frame.near as f32;
        match self.passes.inset.as_ref().filter(|i| !i.four_view()) {
            Some(inset) => passes::gpu_cull::OcclusionTargets {
                sets: &inset.wide.sets,
                extent: inset.wide.extent,
                samples: if inset.wide.sets.iter().all(|s| s.color_msaa.is_some()) {
                    samples
                } else {
                    1
                },
                near,
            },
            None => passes::gpu_cull::OcclusionTargets {
                sets: &self.targets().sets,
                extent: self.targets().extent,
                samples,
                near,
            },
        }
    }
}

/// The request's own checks: the configuration, the auto radii this path
/// cannot resolve, the image size, and four views only with the inset.
fn check_request(
    config: &RenderConfig,
    extent: vk::Extent2D,
    output: Option<&OutputSpec>,
) -> Result<()> {
    config.validate()?;
    if config.effort.rdm_auto || config.effort.foveation == crate::view::foveation::Level::Lens(0) {
        return Err(Error::config(
                "--opt",
                "rdm=auto and foveation=auto need an HMD profile with a lens to derive their radii from (this path does not resolve them); give rdm=R or a foveation level",
            ));
    }
    if extent.width == 0 || extent.height == 0 || extent.width > 16384 || extent.height > 16384 {
        return Err(Error::config(
            "image size",
            format!(
                "{}x{} must be within 1..=16384",
                extent.width, extent.height
            ),
        ));
    }
    if output.is_some_and(|o| o.quad) && config.effort.inset.is_none() {
        return Err(Error::config(
                "output",
                "four views go out only with --opt inset (the runtime's view configuration is quad views)",
            ));
    }
    Ok(())
}

/// The scene on the GPU (with its LOD chains, built or from the cache),
/// the per-draw records, the descriptor sets, and the LOD report; on
/// failure, destroys what it made.
fn upload_scene(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    slots: usize,
) -> Result<(
    SceneGpu,
    Option<DrawRecords>,
    Descriptors,
    Option<LodReport>,
)> {
    let (chains, cache) = match (config.culling.lod, &scene.source) {
        (None, _) => (None, None),
        (Some(_), Some(source)) if config.culling.lod_cache => {
            let (c, used) = crate::scene::lod_cache::load_or_build(scene, source);
            (Some(c), Some(used))
        }
        (Some(_), _) => (Some(crate::scene::lod::build(scene)), None),
    };
    let lod_report = chains.as_ref().map(|c| LodReport {
        levels: c.level_count(),
        index_bytes: c.index_bytes(),
        build_ms: c.build_ms,
        cache,
    });
    let scene_gpu = SceneGpu::new(ctx, scene, chains.as_ref())?;
    drop(chains);
    let draw_records = match DrawRecords::new(ctx, config.submission.per_draw, slots) {
        Ok(r) => r,
        Err(e) => {
            scene_gpu.destroy(ctx);
            return Err(e);
        }
    };
    let extra_set = draw_records.as_ref().map(DrawRecords::set_layout);
    let descriptors = match Descriptors::new(ctx, scene_gpu.textures.len() as u32, slots, extra_set)
    {
        Ok(d) => d,
        Err(e) => {
            if let Some(r) = draw_records {
                r.destroy(ctx);
            }
            scene_gpu.destroy(ctx);
            return Err(e);
        }
    };
    Ok((scene_gpu, draw_records, descriptors, lod_report))
}

/// `config` with the MSAA samples the device gives.
fn with_samples(config: &RenderConfig, samples: u32) -> RenderConfig {
    let mut c = config.clone();
    c.frame.msaa = samples;
    c
}

/// With `inset`: whether its four views go in one scope, and the path's
/// description (`quad`: the output takes the four views as drawn).
fn inset_choice(
    config: &RenderConfig,
    max_views: u32,
    samples: u32,
    quad: bool,
) -> Option<(bool, String)> {
    config.effort.inset.map(|i| {
        let (four, path) = inset_path(i, config.frame.stereo, max_views, samples);
        if quad {
            (four, format!("{path}, submitted as four views"))
        } else {
            (four, path)
        }
    })
}
