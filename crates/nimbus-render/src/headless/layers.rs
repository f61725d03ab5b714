//! The layers of an EXR render beside the radiance: distance along the view
//! ray, the clouds' opacity and the clear sky, for compositing (Blender,
//! Nuke) and for comparing with path-traced references over the cloud
//! pixels (`nimbus compare --mask cloud`).
//!
//! - Distance: from the depth buffer (reverse-Z, infinite far plane: depth =
//!   near / view-space z), times the ray's length per unit of view-space z.
//!   Opaque surfaces only (terrain, objects, cumulus bodies); the stratus
//!   layer, the cumulus fringes and the rain write no depth.
//! - Cloud opacity: the clouds' passes blend linearly over what is behind
//!   them (premultiplied alpha, opaque bodies), so with the background (sky,
//!   terrain, objects) replaced by a grey K and by 0 in two frames without
//!   rain, the difference is K times the clouds' transmittance T. The layer
//!   is 1 − T (luminance-weighted over the channels).
//! - Sky: the same frame with the stratus layer, the cumulus and the rain
//!   removed (the terrain then lies in full sun).

use super::panorama::{self, Filter};
use super::{HeadlessError, HeadlessRenderer};
use crate::frame::{Camera, CubeFace, NEAR_PLANE_M};
use crate::scene::{Projection, Scene};
use glam::DVec3;

/// Distance written where a pixel sees no opaque surface (the sky), m: the
/// value Blender writes for its background.
pub const SKY_DISTANCE_M: f32 = 1e10;

/// Pre-exposed grey that replaces the background in the cloud-opacity
/// frames: well inside half-float range and precision.
const BACKGROUND_PRE_EXPOSED: f32 = 1.0;

/// Rec. 709 luminance weights.
const LUMINANCE_WEIGHTS: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// An image and the layers an EXR render carries with it; rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageLayers {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Linear radiance, W·sr⁻¹·m⁻² per channel (EXR `R`, `G`, `B`).
    pub radiance: Vec<[f32; 3]>,
    /// Distance from the eye to the first opaque surface along the pixel's
    /// ray, m; [`SKY_DISTANCE_M`] where there is none (EXR `Z`).
    pub distance_m: Vec<f32>,
    /// The clouds' opacity (stratus and cumulus, before rain), 0 to 1
    /// (EXR `cloud.A`).
    pub cloud_opacity: Vec<f32>,
    /// Radiance without clouds and rain, W·sr⁻¹·m⁻² (EXR `sky.R`, `sky.G`, `sky.B`).
    pub sky_radiance: Vec<[f32; 3]>,
}

/// The layers of one view (a perspective image or one cube face).
struct ViewLayers {
    radiance: Vec<[f32; 3]>,
    distance_m: Vec<[f32; 1]>,
    cloud_opacity: Vec<[f32; 1]>,
    sky_radiance: Vec<[f32; 3]>,
}

/// A view to draw: its camera, image size, and the ray length per unit of
/// view-space depth at each pixel.
struct View {
    camera: Camera,
    width: u32,
    height: u32,
}

impl View {
    /// Length of the ray per unit of view-space depth through pixel (x, y).
    fn ray_stretch(&self, x: u32, y: u32) -> f64 {
        let tan_half = (self.camera.fov_y_rad * 0.5).tan();
        let s = ((f64::from(x) + 0.5) / f64::from(self.width) * 2.0 - 1.0)
            * tan_half
            * self.camera.aspect;
        let t = (1.0 - (f64::from(y) + 0.5) / f64::from(self.height) * 2.0) * tan_half;
        (1.0 + s * s + t * t).sqrt()
    }
}

/// One layer of the six cube faces (in [`CubeFace::ALL`] order) resampled
/// to the panorama; empty when the faces have none.
fn resample_layer<const C: usize>(
    faces: [Vec<[f32; C]>; 6],
    face_px: u32,
    width: u32,
    height: u32,
    filter: Filter,
) -> Vec<[f32; C]> {
    if faces[0].is_empty() {
        Vec::new()
    } else {
        panorama::resample(&faces, face_px, width, height, filter)
    }
}

/// A one-channel layer as plain values.
fn single_channel(values: Vec<[f32; 1]>) -> Vec<f32> {
    values.into_iter().map(|[v]| v).collect()
}

impl HeadlessRenderer {
    /// Renders a scene with its EXR layers, in the scene camera's
    /// projection. Up to four frames per view: the image, two for the
    /// clouds' opacity (none without clouds) and the clear sky.
    pub fn render_layers(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<ImageLayers, HeadlessError> {
        self.render_layers_selected(scene, width, height, time_s, true)
    }

    /// The layers, or (`all_layers` false) the radiance alone with the
    /// other layers left empty.
    pub(super) fn render_layers_selected(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        time_s: f32,
        all_layers: bool,
    ) -> Result<ImageLayers, HeadlessError> {
        let views: Vec<View> = match scene.camera.projection {
            Projection::Perspective => vec![View {
                camera: Camera::from_settings(&scene.camera, width, height),
                width,
                height,
            }],
            Projection::Equirectangular => {
                let face_px = panorama::face_size_px(width, height);
                let side = panorama::face_side_px(face_px);
                let position_m = DVec3::from_array(scene.camera.position_m);
                CubeFace::ALL
                    .iter()
                    .map(|&face| View {
                        camera: Camera::cube_face(position_m, face, face_px, panorama::OVERSCAN_PX),
                        width: side,
                        height: side,
                    })
                    .collect()
            }
        };
        let layers = self.render_view_layers(scene, &views, time_s, all_layers)?;
        Ok(match scene.camera.projection {
            Projection::Perspective => {
                let Some(view) = layers.into_iter().next() else {
                    unreachable!("one view")
                };
                ImageLayers {
                    width,
                    height,
                    radiance: view.radiance,
                    distance_m: single_channel(view.distance_m),
                    cloud_opacity: single_channel(view.cloud_opacity),
                    sky_radiance: view.sky_radiance,
                }
            }
            Projection::Equirectangular => {
                let face_px = panorama::face_size_px(width, height);
                let mut faces = layers;
                let (n, w, h) = (face_px, width, height);
                let radiance = std::array::from_fn(|f| std::mem::take(&mut faces[f].radiance));
                let distance = std::array::from_fn(|f| std::mem::take(&mut faces[f].distance_m));
                let opacity = std::array::from_fn(|f| std::mem::take(&mut faces[f].cloud_opacity));
                let sky = std::array::from_fn(|f| std::mem::take(&mut faces[f].sky_radiance));
                ImageLayers {
                    width,
                    height,
                    radiance: resample_layer(radiance, n, w, h, Filter::Bilinear),
                    distance_m: single_channel(resample_layer(distance, n, w, h, Filter::Nearest)),
                    cloud_opacity: single_channel(resample_layer(
                        opacity,
                        n,
                        w,
                        h,
                        Filter::Bilinear,
                    )),
                    sky_radiance: resample_layer(sky, n, w, h, Filter::Bilinear),
                }
            }
        })
    }

    /// Renders the layers of each view. The frames are grouped by kind (all
    /// views' images, then their opacity frames, then their clear skies) so
    /// that the clouds and the rain are set up once per kind, not per view.
    fn render_view_layers(
        &mut self,
        scene: &Scene,
        views: &[View],
        time_s: f32,
        all_layers: bool,
    ) -> Result<Vec<ViewLayers>, HeadlessError> {
        let mut out = Vec::with_capacity(views.len());
        for view in views {
            let (radiance, depth) = self.render_view_hdr(
                scene,
                &crate::frame::View::from_camera(&view.camera),
                view.width,
                view.height,
                time_s,
                all_layers,
            )?;
            let distance_m = depth
                .map(|depth| {
                    depth
                        .iter()
                        .enumerate()
                        .map(|(i, &d)| {
                            if d <= 0.0 {
                                return [SKY_DISTANCE_M];
                            }
                            let (x, y) = (i as u32 % view.width, i as u32 / view.width);
                            [(NEAR_PLANE_M / f64::from(d) * view.ray_stretch(x, y)) as f32]
                        })
                        .collect()
                })
                .unwrap_or_default();
            out.push(ViewLayers {
                radiance,
                distance_m,
                cloud_opacity: Vec::new(),
                sky_radiance: Vec::new(),
            });
        }
        if !all_layers {
            return Ok(out);
        }
        // The clouds' opacity, from two frames over a grey and a black
        // background, without rain and at a fixed exposure.
        let has_clouds = scene.stratus.is_some() || scene.cumulus.is_some();
        let mut masked = scene.without_rain();
        masked.camera.auto_exposure = false;
        for (view, layers) in views.iter().zip(out.iter_mut()) {
            let pixels = (view.width * view.height) as usize;
            if !has_clouds {
                layers.cloud_opacity = vec![[0.0]; pixels];
                continue;
            }
            let grey =
                self.render_over_background(&masked, view, time_s, BACKGROUND_PRE_EXPOSED)?;
            // The background's radiance: the pre-exposed grey over the
            // pre-exposure that frame used.
            let background_radiance = self.pre_exposed_to_radiance(BACKGROUND_PRE_EXPOSED)?;
            let black = self.render_over_background(&masked, view, time_s, 0.0)?;
            layers.cloud_opacity = grey
                .iter()
                .zip(&black)
                .map(|(g, b)| {
                    let transmitted: f32 = (0..3)
                        .map(|k| LUMINANCE_WEIGHTS[k] * (g[k] - b[k]))
                        .sum::<f32>()
                        / background_radiance;
                    [(1.0 - transmitted).clamp(0.0, 1.0)]
                })
                .collect();
        }
        let clear = scene.clear_sky();
        for (view, layers) in views.iter().zip(out.iter_mut()) {
            let (sky, _) = self.render_view_hdr(
                &clear,
                &crate::frame::View::from_camera(&view.camera),
                view.width,
                view.height,
                time_s,
                false,
            )?;
            layers.sky_radiance = sky;
        }
        Ok(out)
    }

    /// The radiance of a view drawn with its background (sky, terrain,
    /// objects) replaced by a grey of this pre-exposed value.
    fn render_over_background(
        &mut self,
        scene: &Scene,
        view: &View,
        time_s: f32,
        pre_exposed: f32,
    ) -> Result<Vec<[f32; 3]>, HeadlessError> {
        self.renderer.set_background_override(Some(pre_exposed));
        let frame = self.render_view_hdr(
            scene,
            &crate::frame::View::from_camera(&view.camera),
            view.width,
            view.height,
            time_s,
            false,
        );
        self.renderer.set_background_override(None);
        Ok(frame?.0)
    }

    /// The radiance a pre-exposed value of the last frame stands for.
    fn pre_exposed_to_radiance(&self, pre_exposed: f32) -> Result<f32, HeadlessError> {
        let lighting: crate::passes::atmosphere::LightingUniform =
            self.read_buffer(&self.renderer.frame_resources().atmosphere.lighting)?;
        Ok(pre_exposed / lighting.exposure[0])
    }

    /// Renders a panorama tone-mapped on the CPU with one exposure for the
    /// whole sphere: the scene's, or metered over the sphere when automatic.
    pub(super) fn render_equirectangular_rgba8(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<super::Rgba8Image, HeadlessError> {
        let layers = self.render_layers_selected(scene, width, height, time_s, false)?;
        let camera = &scene.camera;
        let ev100 = if camera.auto_exposure {
            let average = panorama::log_average_luminance_cd_m2(&layers.radiance, width, height);
            // exposure.wgsl: EV100 = log2(L·S/K) with S = 100, K = 12.5.
            (average * 100.0 / 12.5).log2() - camera.exposure_compensation_ev
        } else {
            camera.exposure_ev100
        };
        let scale = nimbus_physics::photometry::exposure_scale_from_ev100(ev100);
        Ok(super::Rgba8Image {
            width,
            height,
            pixels: panorama::tonemap_rgba8(&layers.radiance, scale),
        })
    }
}
