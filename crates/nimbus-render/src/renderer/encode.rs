//! Recording a frame: the passes in their order.

use super::{FrameTargets, PassId, PassSet, Renderer, TargetLoad};
use crate::core::targets::{FAR_DEPTH, Target, colour_pass};
use crate::passes::cumulus::MarchGroup;
use std::sync::atomic::Ordering;

/// Set in `Renderer::lighting_recorded` when `encode_lighting` recorded
/// the frame's lighting (the other bits: the passes it ran).
const LIGHTING_RECORDED: u32 = 1 << 31;

impl Renderer {
    /// Records the frame: the atmosphere's LUTs, the clouds' lighting and
    /// shadows, the rain's simulation, then sky, terrain, objects, clouds,
    /// mist and rain into the HDR target, exposure and tone mapping into the
    /// caller's output. Call [`Self::prepare`] first.
    ///
    /// In [`super::OutputMode::LinearHdr`] the caller's depth is first
    /// translated into nimbus's own depth target, the air in front of the
    /// caller's surfaces drawn, and at the end nimbus's target composited
    /// over the caller's colour instead of exposure and tone mapping.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, targets: &FrameTargets<'_>) {
        let Some(hdr) = &self.hdr else { return };
        // The depth every pass tests against and reads: the caller's in
        // Display mode, nimbus's own (the caller's translated) in LinearHdr.
        let linear = self.composite.as_ref().zip(self.own_depth.as_ref());
        let depth = linear.map_or(targets.depth, |(_, own)| &own.view);
        let frame = self.frame.bindings();
        // 1–3. The lighting work, unless `encode_lighting` recorded it already.
        let recorded = self.lighting_recorded.swap(0, Ordering::Relaxed);
        let mut run = if recorded & LIGHTING_RECORDED != 0 {
            PassSet::from_bits(recorded & !LIGHTING_RECORDED)
        } else {
            self.record_lighting(encoder)
        };
        let rain = self.rain.enabled();
        let (color_load, depth_load) = match (linear, targets.load) {
            // Transparent: alpha is the coverage of the caller's pixel.
            (Some((composite, own)), _) => {
                composite.encode_depth_import(
                    &self.device,
                    encoder,
                    targets.depth,
                    &own.view,
                    &frame,
                    self.timer
                        .as_ref()
                        .map(|t| t.pass_writes(PassId::CallerDepth.timer_index())),
                );
                (
                    wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    wgpu::LoadOp::Load,
                )
            }
            (None, TargetLoad::Clear) => (
                wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                wgpu::LoadOp::Clear(FAR_DEPTH),
            ),
            (None, TargetLoad::Keep) => (wgpu::LoadOp::Load, wgpu::LoadOp::Load),
        };
        let cumulus = self.cumulus.enabled();
        if !cumulus {
            for id in [
                PassId::Cumulus,
                PassId::CumulusFringes,
                PassId::CumulusComposite,
            ] {
                run.remove(id);
            }
        }
        let in_layer = self.stratus.enabled() && self.stratus.in_layer_active();
        if !in_layer {
            run.remove(PassId::StratusInLayer);
        }
        let in_cloud = self.cumulus.in_cloud_active();
        let volume = self.cumulus.volume_active();
        if !in_cloud && !volume {
            run.remove(PassId::CumulusInCloudLight);
            run.remove(PassId::CumulusInCloud);
        }
        // The marched clouds' light atlases are kept while the lighting
        // and the clouds' scale and yaw hold.
        let lighting_generation = self.atmosphere.lighting_generation();
        if !self.cumulus.in_cloud_light_pending(lighting_generation) {
            run.remove(PassId::CumulusInCloudLight);
        }
        if !self.objects.enabled() {
            run.remove(PassId::Objects);
        }
        if linear.is_some() {
            run.remove(PassId::Exposure);
            run.remove(PassId::Tonemap);
        } else {
            for id in [PassId::CallerDepth, PassId::CallerAir, PassId::Export] {
                run.remove(id);
            }
        }
        self.passes_run.store(run.bits(), Ordering::Relaxed);
        // 4. Sky, sun and open sea, at the far plane.
        {
            let mut pass = self.hdr_pass(
                encoder,
                "sky",
                PassId::Sky,
                hdr,
                depth,
                color_load,
                depth_load,
            );
            self.sky.draw(&mut pass, &frame);
        }
        // 4b. The air in front of the caller's surfaces (the only ones in
        // the depth so far), before nimbus's own surfaces cover some of them.
        if let Some((composite, _)) = linear {
            let mut pass = self.overlay_pass(
                encoder,
                "caller aerial perspective",
                PassId::CallerAir,
                hdr,
                None,
            );
            composite.draw_aerial(&mut pass, &frame);
        }
        // 5. Terrain, depth-tested.
        {
            let mut pass = self.hdr_pass(
                encoder,
                "terrain",
                PassId::Terrain,
                hdr,
                depth,
                wgpu::LoadOp::Load,
                wgpu::LoadOp::Load,
            );
            self.terrain.draw(&mut pass, &frame);
        }
        // 5b. Static objects (boxes, glTF meshes), depth-tested like the terrain.
        if self.objects.enabled() {
            let mut pass = self.hdr_pass(
                encoder,
                "objects",
                PassId::Objects,
                hdr,
                depth,
                wgpu::LoadOp::Load,
                wgpu::LoadOp::Load,
            );
            self.objects.draw(&mut pass, &frame);
        }
        // 5c. For the cloud-opacity layer: the background replaced by a
        // known constant (the depth kept), so that the clouds' transmittance
        // can be read from two frames (see `headless::HeadlessRenderer::render_layers`).
        if let Some(value) = self.background_override {
            encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("background override"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &hdr.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: f64::from(value),
                            g: f64::from(value),
                            b: f64::from(value),
                            a: 0.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        }
        // 6. Cumulus: opaque bodies (depth written), then the fringes'
        // order-independent accumulation against that depth.
        if cumulus {
            {
                let mut pass = self.hdr_pass(
                    encoder,
                    "cumulus",
                    PassId::Cumulus,
                    hdr,
                    depth,
                    wgpu::LoadOp::Load,
                    wgpu::LoadOp::Load,
                );
                self.cumulus.draw_opaque(&mut pass, &frame);
            }
            self.cumulus.encode_fringes(
                encoder,
                depth,
                &frame,
                self.timer
                    .as_ref()
                    .map(|t| t.pass_writes(PassId::CumulusFringes.timer_index())),
            );
        }
        // The cumulus marches, of the volume model (6b, and 7b for the
        // clouds between the camera and the stratus layer) or of the cloud
        // the camera is in or near (8e).
        let cumulus_marches = |encoder: &mut wgpu::CommandEncoder, group: MarchGroup| {
            let writes = |id: PassId| self.timer.as_ref().map(|t| t.pass_writes(id.timer_index()));
            self.cumulus.encode_in_cloud(
                encoder,
                &hdr.view,
                depth,
                &frame,
                lighting_generation,
                group,
                writes(PassId::CumulusInCloudLight),
                writes(PassId::CumulusInCloud),
            );
        };
        // 6b. The volume model: the clouds in view marched as volumes over
        // what is behind them, writing the depth of their bodies (those
        // wholly in front of the stratus layer wait for it, 7b).
        if volume {
            cumulus_marches(encoder, MarchGroup::BehindOrAmongLayer);
        }
        let marches_in_front_of_layer = self.cumulus.volume_in_front_of_layer();
        // 7. The stratus layer, blended over sky, terrain and cumulus bodies,
        // depth-tested; or, for a layer marched as a volume and seen from
        // below, the march there (the mist and rain under it are in front).
        let layer_march = |encoder: &mut wgpu::CommandEncoder| {
            self.stratus.encode_in_layer(
                encoder,
                &hdr.view,
                depth,
                &frame,
                self.timer
                    .as_ref()
                    .map(|t| t.pass_writes(PassId::StratusInLayer.timer_index())),
            );
        };
        let layer_marched_early = in_layer && self.stratus.marches_before_overlays();
        let layer_marched_late = in_layer && !layer_marched_early;
        if layer_marched_early {
            layer_march(encoder);
        }
        if self.stratus.enabled() {
            let mut pass = self.hdr_pass(
                encoder,
                "stratus",
                PassId::Stratus,
                hdr,
                depth,
                wgpu::LoadOp::Load,
                wgpu::LoadOp::Load,
            );
            self.stratus.draw(&mut pass, &frame);
        }
        // 7b. The volume model's clouds wholly between the camera and the
        // layer, over it: the layer would otherwise come out in front of
        // their fog wherever it is thinner than opaque (in_cloud::MarchGroup).
        if marches_in_front_of_layer && !layer_marched_late {
            cumulus_marches(encoder, MarchGroup::InFrontOfLayer);
        }
        // 8. The cumulus fringes over everything behind them.
        if cumulus {
            let mut pass = self.overlay_pass(
                encoder,
                "cumulus composite",
                PassId::CumulusComposite,
                hdr,
                None,
            );
            self.cumulus.draw_composite(&mut pass);
        }
        // 8b. Rain mist beyond the rain box, over everything (reads the depth).
        if self.rain.mist_enabled() {
            let mut pass = self.overlay_pass(encoder, "rain mist", PassId::RainMist, hdr, None);
            self.rain.draw_mist(&mut pass, depth, &frame);
        }
        // 8c. Rain streaks and splashes, depth-tested against a read-only
        // depth that they also read, to fade where they meet surfaces.
        if rain {
            let mut pass = self.overlay_pass(encoder, "rain", PassId::Rain, hdr, Some(depth));
            self.rain.draw(&mut pass, depth, &frame);
        }
        // 8d. The camera in or near the stratus layer's height range: the
        // layer marched as a volume over everything (its faces faded out).
        if layer_marched_late {
            layer_march(encoder);
            // The layer complete, the clouds in front of it (7b).
            if marches_in_front_of_layer {
                cumulus_marches(encoder, MarchGroup::InFrontOfLayer);
            }
        }
        // 8e. The camera in or near a cumulus: that cloud marched as a
        // volume over everything (its mesh faded out), attenuating what is
        // behind it — the caller's surfaces included, through the depth.
        if in_cloud {
            cumulus_marches(encoder, MarchGroup::BehindOrAmongLayer);
        }
        // 9–10 in LinearHdr: nimbus's target over the caller's colour; the
        // caller exposes and tone maps.
        if let Some((composite, _)) = linear {
            let timestamps = self
                .timer
                .as_ref()
                .map(|t| t.pass_writes(PassId::Export.timer_index()));
            let mut pass = colour_pass(encoder, "export", targets.output, None, timestamps);
            composite.draw_export(&mut pass, &frame);
            drop(pass);
            if let Some(timer) = &self.timer {
                timer.resolve(encoder);
            }
            return;
        }
        // 9. Exposure: meter the frame (automatic exposure) or pass the manual EV through.
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("exposure"),
                timestamp_writes: self
                    .timer
                    .as_ref()
                    .map(|t| t.compute_pass_writes(PassId::Exposure.timer_index())),
            });
            self.exposure.encode(&mut pass, frame.frame);
        }
        // 10. Tone map into the caller's output.
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("tonemap"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: targets.output,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: self
                    .timer
                    .as_ref()
                    .map(|t| t.pass_writes(PassId::Tonemap.timer_index())),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.tonemap.draw(&mut pass);
        }
        if let Some(timer) = &self.timer {
            timer.resolve(encoder);
        }
    }

    /// Records the frame's lighting work: the atmosphere's LUTs and lighting
    /// inputs (where they changed), the stratus layer's thickness and
    /// radiosity, the cumulus shadow map and the rain's simulation: what
    /// the caller's own pipelines read through nimbus's WGSL include
    /// ([`crate::shader::lighting_include`]). Record it before drawing
    /// them, so that they see this frame's cloud shadows; [`Self::encode`]
    /// then does not record it again. Call after [`Self::prepare_view`].
    pub fn encode_lighting(&self, encoder: &mut wgpu::CommandEncoder) {
        let run = self.record_lighting(encoder);
        self.lighting_recorded
            .store(run.bits() | LIGHTING_RECORDED, Ordering::Relaxed);
    }

    /// Steps 1–3 of the frame; returns every pass with those that had
    /// nothing to do removed.
    fn record_lighting(&self, encoder: &mut wgpu::CommandEncoder) -> PassSet {
        let mut run = PassSet::all();
        let frame = self.frame.bindings();
        // 1. Atmosphere: LUTs, aerial perspective and lighting inputs, where their inputs changed.
        let atmosphere_run = self
            .atmosphere
            .encode(encoder, frame.frame, self.timer.as_ref(), 0);
        for (id, ran) in PassId::ATMOSPHERE.into_iter().zip(atmosphere_run) {
            if !ran {
                run.remove(id);
            }
        }
        // 2. The stratus layer's thickness field and ground–cloud radiosity.
        if self.stratus.enabled() {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("stratus lighting"),
                timestamp_writes: self
                    .timer
                    .as_ref()
                    .map(|t| t.compute_pass_writes(PassId::StratusLighting.timer_index())),
            });
            self.stratus.encode_compute(&mut pass, &frame);
        } else {
            run.remove(PassId::StratusLighting);
            run.remove(PassId::Stratus);
        }
        // 3. The cumulus shadow map, when what it shows has changed.
        self.cumulus.encode_shadow(
            encoder,
            &frame,
            self.frame.cloud_lighting.shadow(),
            self.timer
                .as_ref()
                .map(|t| (t.query_set(), PassId::CumulusShadow.timer_index())),
        );
        if !self.cumulus.shadow_redrawn() {
            run.remove(PassId::CumulusShadow);
        }
        // 3b. The rain: its shadow map when needed, the steps since the last
        // frame, and the list of drops in view.
        if self.rain.enabled() {
            self.rain.encode_simulation(
                encoder,
                &frame,
                &self.occluders(),
                self.timer
                    .as_ref()
                    .map(|t| t.compute_pass_writes(PassId::RainSimulation.timer_index())),
            );
        } else {
            for id in [PassId::RainSimulation, PassId::Rain] {
                run.remove(id);
            }
        }
        if !self.rain.mist_enabled() {
            run.remove(PassId::RainMist);
        }
        run
    }

    /// A pass drawing over the HDR target as it is (colour loaded and kept),
    /// with the depth attached read-only when given.
    fn overlay_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
        id: PassId,
        hdr: &Target,
        read_only_depth: Option<&wgpu::TextureView>,
    ) -> wgpu::RenderPass<'e> {
        let timestamps = self.timer.as_ref().map(|t| t.pass_writes(id.timer_index()));
        colour_pass(encoder, label, &hdr.view, read_only_depth, timestamps)
    }

    #[allow(clippy::too_many_arguments)]
    fn hdr_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
        id: PassId,
        hdr: &Target,
        depth: &wgpu::TextureView,
        color_load: wgpu::LoadOp<wgpu::Color>,
        depth_load: wgpu::LoadOp<f32>,
    ) -> wgpu::RenderPass<'e> {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &hdr.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: color_load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: depth_load,
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: self.timer.as_ref().map(|t| t.pass_writes(id.timer_index())),
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }
}
