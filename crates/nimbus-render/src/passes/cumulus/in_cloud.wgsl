// import passes/cumulus/cumulus.wgsl
// import shader/cloud_shadow_lookup.wgsl
// import shader/terrain_shadow_lookup.wgsl
// import shader/diffusion.wgsl
// import shader/fullscreen.wgsl
// The view from inside a cumulus (or near enough that its mesh hands over):
// the cloud as the participating medium the mesh stands for, marched from
// the camera through the variant's extinction (the same grid the path-traced
// references render, δ-M scaled) to the first opaque surface or out of the
// cloud's box, lit by the transport model's light: the sky's scattered light
// inside, precomputed per shape (nimbus_physics::cumulus::interior), the
// sun's scattered light towards the camera from the sun cube traced for this
// cloud and sun (isotropic with a forward lobe until it is ready), and the
// sun's single scattering
// through the peak-removed phase function with the direct beam's
// transmittance marched through the cloud's own grid. Twin of
// nimbus_physics::cumulus::interior::march_fog. Drawn over everything
// (premultiplied: dst·(1 − fade·(1 − T)) + fade·L).

struct InCloud {
    // World position of the variant's origin, m, and the cloud's scale.
    offset_scale: vec4<f32>,
    // cos yaw, sin yaw, the march's weight (the mesh's fade), steps.
    rotation: vec4<f32>,
    // The extinction's box in the object frame (min xyz, m) and δ-M's 1 − f.
    extinction_min: vec4<f32>,
    // Its size (m) and the light's weight between its two scales.
    extinction_size: vec4<f32>,
    // The light's box in the object frame (min xyz, m), and the weight of
    // the sky's direct light (1 in the volume model, else 0).
    light_min: vec4<f32>,
    // Its size, m, unused.
    light_size: vec4<f32>,
    // The light's cells along x, y, z, and 1 when the sun cube (over the
    // light's box) is this instance's.
    light_dims: vec4<u32>,
}

@group(1) @binding(3) var<uniform> in_cloud: InCloud;
// σ_t (before δ-M), m⁻¹, over the extinction's box.
@group(1) @binding(4) var in_cloud_extinction: texture_3d<f32>;
// The light's cells as an atlas of z slices stacked in y: rgb the sky's
// scattered fluence Σ Φ_k L_k (W m⁻², pre-exposure not applied), a the
// sun's per unit irradiance Σ Φ_k Y_k(l); beside them (x + nx) the direct
// transmittance from the sky, its mean t̄ and first moment b, then (x + 2 nx)
// the sky's scattered light's net flux Σ_k F_k L_k (luminance, world) and in
// a the scattered fluence of a unit irradiance from a uniform ground below.
@group(1) @binding(5) var in_cloud_light: texture_2d<f32>;
@group(1) @binding(6) var in_cloud_sampler: sampler;
// The depth buffer, read only by the copy each march reads (binding 11):
// the volume marches write the depth buffer.
@group(1) @binding(7) var in_cloud_depth: texture_depth_2d;
// The light pass's input: per cell, the quadratic forms of the scattered
// fluence at the two scales, then of the direct fluence, then the scattered
// light's net flux F_0 … F_3 (interior.rs VariantInterior::light_forms).
@group(1) @binding(8) var<storage, read> in_cloud_forms: array<vec4<f32>>;
const IN_CLOUD_LIGHT_FORMS: u32 = 18u;
// Parts of the light atlas side by side (interior.rs LIGHT_PARTS).
const IN_CLOUD_LIGHT_PARTS: f32 = 3.0;
// Rec. 709 luminance weights.
const IN_CLOUD_LUMA: vec3<f32> = vec3<f32>(0.2126, 0.7152, 0.0722);
// The sun cube (interior.rs VariantSunCube) over the light's box: rgb the
// sun's directional fluence per unit irradiance towards +x, +y, +z and a its
// excess along the beam over the cube's reading there; then towards −x, −y,
// −z and a the fluence (object frame).
@group(1) @binding(9) var in_cloud_sun_cube_positive: texture_3d<f32>;
@group(1) @binding(10) var in_cloud_sun_cube_negative: texture_3d<f32>;
// The depth buffer as it was before this march (reverse-Z).
@group(1) @binding(11) var in_cloud_scene_depth: texture_2d<f32>;

// The sun's direct beam is evaluated at this many points of a view ray and
// held between them, each marched towards the sun in IN_CLOUD_SUN_STEPS.
const IN_CLOUD_SHADOW_SEGMENTS: u32 = 8u;
const IN_CLOUD_SUN_STEPS: u32 = 16u;
// Strides of the search for the cloud along a view ray through its box.
const IN_CLOUD_SKIP_STEPS: u32 = 64u;

// The object frame's point of a world point (inverse of cumulus_varying's).
fn in_cloud_object(world_m: vec3<f32>) -> vec3<f32> {
    let d = world_m - in_cloud.offset_scale.xyz;
    let c = in_cloud.rotation.x;
    let s = in_cloud.rotation.y;
    return vec3<f32>(c * d.x - s * d.z, d.y, s * d.x + c * d.z) / in_cloud.offset_scale.w;
}

// σ* = (1 − f) σ at an object point, m⁻¹ (world metres: the cloud at scale
// s is the unscaled shape with the same α_ρ, as the references scale it).
fn in_cloud_sigma(object_m: vec3<f32>) -> f32 {
    let uvw = (object_m - in_cloud.extinction_min.xyz) / in_cloud.extinction_size.xyz;
    if (any(uvw < vec3<f32>(0.0)) || any(uvw > vec3<f32>(1.0))) {
        return 0.0;
    }
    return textureSampleLevel(in_cloud_extinction, in_cloud_sampler, uvw, 0.0).r * in_cloud.extinction_min.w;
}

// Where an object point reads the light atlas: trilinear between cell
// centres, clamped to the edge cells, as two bilinear lookups of the
// atlas's z slices (their rows, the blend between them; x in the first
// part).
struct InCloudLightTexel {
    x: f32,
    row_0: f32,
    row_1: f32,
    blend: f32,
}

fn in_cloud_light_texel(object_m: vec3<f32>) -> InCloudLightTexel {
    let dims = vec3<f32>(in_cloud.light_dims.xyz);
    let u = (object_m - in_cloud.light_min.xyz) / in_cloud.light_size.xyz * dims;
    let z = clamp(u.z - 0.5, 0.0, dims.z - 1.0);
    let k0 = floor(z);
    let k1 = min(k0 + 1.0, dims.z - 1.0);
    let y = clamp(u.y, 0.5, dims.y - 0.5);
    let height = dims.y * dims.z;
    var out: InCloudLightTexel;
    out.x = clamp(u.x, 0.5, dims.x - 0.5) / (IN_CLOUD_LIGHT_PARTS * dims.x);
    out.row_0 = (y + k0 * dims.y) / height;
    out.row_1 = (y + k1 * dims.y) / height;
    out.blend = z - k0;
    return out;
}

// The light there: `part` 0 the scattered light, 1 the direct
// transmittance from the sky, 2 the sky's scattered light's net flux.
fn in_cloud_light_at(at: InCloudLightTexel, part: f32) -> vec4<f32> {
    let x = at.x + part / IN_CLOUD_LIGHT_PARTS;
    let a = textureSampleLevel(in_cloud_light, in_cloud_sampler, vec2<f32>(x, at.row_0), 0.0);
    let b = textureSampleLevel(in_cloud_light, in_cloud_sampler, vec2<f32>(x, at.row_1), 0.0);
    return mix(a, b, at.blend);
}

// The sun's directional fluence per unit irradiance at an object point
// towards `toward` (unit, object frame), from the sun cube (trilinear
// between cell centres, clamped to the edge cells), its excess along the
// beam spread by `shape`.
fn in_cloud_sun_toward(object_m: vec3<f32>, toward: vec3<f32>, shape: f32) -> f32 {
    let uvw = (object_m - in_cloud.light_min.xyz) / in_cloud.light_size.xyz;
    let positive = textureSampleLevel(in_cloud_sun_cube_positive, in_cloud_sampler, uvw, 0.0);
    let negative = textureSampleLevel(in_cloud_sun_cube_negative, in_cloud_sampler, uvw, 0.0);
    return sun_cube_toward(positive.rgb, negative.rgb, positive.a, toward, shape);
}

// The direct beam's optical depth from the sun to an object point through
// the cloud's own extinction: σ* integrated to where the sun's ray leaves
// the box, in steps t_j = L (j/N)² (fine near the point, where the beam
// dims over the ~20 m of its mean free path). Returns the world point where
// the ray leaves the box and τ* (the beam's transmittance is e^{−τ*}; the
// forward peak reads τ* itself).
fn in_cloud_own_depth(object_m: vec3<f32>, object_sun: vec3<f32>) -> vec4<f32> {
    let length_m = max(in_cloud_box(object_m, object_sun).y, 0.0);
    var optical_depth = 0.0;
    for (var j = 0u; j < IN_CLOUD_SUN_STEPS; j += 1u) {
        let a = f32(j) / f32(IN_CLOUD_SUN_STEPS);
        let b = f32(j + 1u) / f32(IN_CLOUD_SUN_STEPS);
        let t = length_m * 0.5 * (a * a + b * b);
        optical_depth += in_cloud_sigma(object_m + object_sun * t) * length_m * (b * b - a * a);
    }
    return vec4<f32>(in_cloud_world(object_m + object_sun * length_m), optical_depth);
}

// The direct beam's transmittance through the clouds beyond this one's box,
// from the shadow map's cores at the point `exit_m` where the beam leaves
// the box: cumulus_direct_transmittance's inversion of the map's two-stream
// diffuse transmittance T_d = 1/(1 + ¾(1 − g) σ Δ) to e^{−σ* Δ}.
fn in_cloud_beyond_transmittance(exit_m: vec3<f32>) -> f32 {
    let diffuse = cloud_shadow_transmittance(exit_m);
    let optical_depth = (1.0 / max(diffuse, 1e-6) - 1.0) / (0.75 * (1.0 - cloud_shadow.params.z));
    return exp(-optical_depth * in_cloud.extinction_min.w);
}

// The world point of an object point (cumulus_varying's transform).
fn in_cloud_world(object_m: vec3<f32>) -> vec3<f32> {
    return in_cloud.offset_scale.xyz + cumulus_rotate(object_m * in_cloud.offset_scale.w, in_cloud.rotation.x, in_cloud.rotation.y);
}

// How far across the sun's beam the stratus layer's shadow on the light a
// cloud scatters many times is averaged, m: about the transport mean free
// path (~90 m), over which that light has spread.
const IN_CLOUD_LAYER_SHADOW_SPREAD_M: f32 = 120.0;

// The stratus layer's and the terrain's shadow on the sunlight that the
// cloud scatters many times, near `position_m`: their transmittance at the
// point and at four points IN_CLOUD_LAYER_SHADOW_SPREAD_M away across the
// beam. The light a point scatters many times entered the cloud near the
// sunlit surface in front of it along the beam, whose rays cross the layer
// where the point's own do; averaged across the beam, so the layer's cells draw
// soft shafts through the fog rather than sharp dark columns. One mean
// over the cloud (five points of its box's top, before) saw one cell where
// a cloud's sunlit side was under another: under the default scene's
// broken deck and a sun 22° high, a cumulus whose reference lost 61 % of
// its sunlight to the deck kept all of it (docs/REALISM.md, "A cumulus
// under a broken deck").
fn in_cloud_layer_shadow(position_m: vec3<f32>) -> vec3<f32> {
    let l = frame.sun_direction;
    var across = vec3<f32>(-l.z, 0.0, l.x);
    across = across / max(length(across), 1e-6);
    let other = cross(l, across);
    let r = IN_CLOUD_LAYER_SHADOW_SPREAD_M;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < 5u; k += 1u) {
        var p = position_m;
        if (k > 0u) {
            let sign = select(-1.0, 1.0, (k & 1u) == 1u);
            p += sign * r * select(other, across, k < 3u);
        }
        sum += stratus_sun_transmittance(p) * terrain_sun_visibility(p);
    }
    return 0.2 * sum;
}

// A light cell's form vector `index` at the cloud's scale: between its
// values at the two scales (the second three vectors on).
fn in_cloud_scaled_form(index: u32) -> vec4<f32> {
    return mix(in_cloud_forms[index], in_cloud_forms[index + 3u], in_cloud.extinction_size.w);
}

// The quadratic form whose vectors start at `index`, at the cloud's scale,
// turned to the world.
fn in_cloud_turned_form(index: u32) -> CumulusTransfer {
    return cumulus_turned_transfer(in_cloud_scaled_form(index), in_cloud_scaled_form(index + 1u), in_cloud_scaled_form(index + 2u), in_cloud.rotation.xy);
}

// The light pass: one fragment per cell of the atlas, the forms at the
// cloud's scale turned to the world (b → R b, A → R A Rᵀ) and integrated
// against the sun and the sky. The atlas's second part holds each cell's
// direct transmittance from the sky by its orders ≤ 1 (the direct fluence's:
// its mean over directions c + tr A/3 and first moment b), which the march
// scatters towards the camera through the phase function as a cap of open
// sky (transmittance_cap); its third the
// sky's scattered light's net flux.
@fragment
fn in_cloud_light_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    let dims = in_cloud.light_dims;
    let texel = vec2<u32>(in.position.xy);
    let x = texel.x % dims.x;
    let cell = (texel.y / dims.y) * dims.y * dims.x + (texel.y % dims.y) * dims.x + x;
    let at = IN_CLOUD_LIGHT_FORMS * cell;
    if (texel.x >= 2u * dims.x) {
        // The sky's scattered light's net flux Σ_k F_k L_k (luminance),
        // the sky's orders ≤ 1 turned into the object frame and the flux
        // back out.
        let a = in_cloud_scaled_form(at + 12u);
        let b = in_cloud_scaled_form(at + 13u);
        let c = in_cloud_scaled_form(at + 14u);
        let luma = IN_CLOUD_LUMA;
        let sky_0 = dot(lighting.clouds_sh[0].xyz, luma);
        let sky_world = vec3<f32>(dot(lighting.clouds_sh[3].xyz, luma), dot(lighting.clouds_sh[1].xyz, luma), dot(lighting.clouds_sh[2].xyz, luma));
        let sky = in_cloud_object_direction(sky_world) * in_cloud.offset_scale.w;
        let flux = sky_0 * a.xyz + sky.y * vec3<f32>(a.w, b.xy) + sky.z * vec3<f32>(b.zw, c.x) + sky.x * c.yzw;
        // Beside it, the scattered fluence of a unit irradiance from a
        // uniform ground below (the SH of stratus_layered_lighting's G),
        // which the march adds under a stratus layer as the mesh does.
        var ground = lighting;
        for (var k = 0u; k < 9u; k += 1u) {
            ground.sh[k] = vec4<f32>(0.0);
        }
        ground.sh[0] = vec4<f32>(vec3<f32>(STRATUS_GROUND_SH_0), 0.0);
        ground.sh[1] = vec4<f32>(vec3<f32>(STRATUS_GROUND_SH_Y), 0.0);
        let ground_fluence = cumulus_transfer_environment(in_cloud_turned_form(at), ground).y;
        return vec4<f32>(cumulus_rotate(flux, in_cloud.rotation.x, in_cloud.rotation.y), ground_fluence);
    }
    if (texel.x >= dims.x) {
        let direct = in_cloud_turned_form(at + 6u);
        let a = direct.diagonal_xy.xyz;
        return vec4<f32>(direct.c_b.x + (a.x + a.y + a.z) / 3.0, direct.c_b.yzw);
    }
    let f = in_cloud_turned_form(at);
    let environment = max(cumulus_transfer_environment(f, clouds_lighting(lighting)), vec3<f32>(0.0));
    let sun = max(cumulus_transfer_value(f, frame.sun_direction), 0.0);
    return vec4<f32>(environment, sun);
}

struct InCloudMarch {
    // Pre-exposure not applied.
    radiance: vec3<f32>,
    transmittance: f32,
    // The point of the ray where its light was scattered, on average (for
    // the air in front of it), m.
    mean_m: vec3<f32>,
    // Where the transmittance first fell below ½ (the body's depth), m
    // along the ray; negative if it did not.
    opaque_t: f32,
}

// The object frame's direction of a world direction, per world metre (the
// object frame is the world's turned and divided by the cloud's scale).
fn in_cloud_object_direction(direction: vec3<f32>) -> vec3<f32> {
    let c = in_cloud.rotation.x;
    let s = in_cloud.rotation.y;
    return vec3<f32>(c * direction.x - s * direction.z, direction.y, s * direction.x + c * direction.z) / in_cloud.offset_scale.w;
}

// Steps at t_i = t₀ + (t₁ − t₀)(i/N)²: fine near the camera, where the
// cloud's edge is crossed, long far away.
fn in_cloud_march(origin_m: vec3<f32>, direction: vec3<f32>, t0: f32, t1: f32) -> InCloudMarch {
    let steps = u32(in_cloud.rotation.w);
    let l = frame.sun_direction;
    let phase = cumulus_phase(dot(direction, l));
    // Under a stratus layer the light that is there (stratus_under_light),
    // as the mesh's shading takes it (stratus_layered_lighting): the
    // scattered fluence's luminance scaled to the layer's R_G, taking its
    // colour, and the ground's light replaced by the radiosity's R_C through
    // the fluence of a uniform lower hemisphere (the light atlas's third
    // part); the sky's direct light from the layered SH. (Tried before the
    // marches in front of the layer were drawn after it, the darker fog made
    // the flight through a cumulus under a deck step: docs/REALISM.md, "The
    // fog's hard edge under a deck".)
    let under = stratus_under_light(clouds_lighting(lighting), origin_m + direction * t0);
    let luma = IN_CLOUD_LUMA;
    // δ-M's peak-removed asymmetry g* = (g − f)/(1 − f).
    let truncation = in_cloud.extinction_min.w;
    let asymmetry = (cloud_shadow.params.z - (1.0 - truncation)) / truncation;
    // Evaluated at the middles of segments of the ray and held over each
    // (texture lookups in the loop are what costs on llvmpipe; the beam
    // varies over tens of metres, the layer's shadow over cells), with the
    // forward lobe of the sun's scattered light at the beam's depth there.
    //
    // The direct beam at each point: through this cloud by its own grid,
    // through the clouds beyond its box by the shadow map (read at every
    // other point, its percentage-closer filter being the costly part;
    // other clouds' shadows vary over their cores, not over this cloud's
    // faces), and through the stratus layer. The map alone, used before,
    // counts the cores only, each as a slab of α_ρ: inside the sunlit face
    // it gave 0.58× the grid's transmittance (docs/REALISM.md, "In-cloud
    // views").
    let object_sun = in_cloud_object_direction(l);
    let object_sun_unit = normalize(object_sun);
    // The light towards the camera, in the object frame (the sun cube's).
    let toward_camera = -normalize(in_cloud_object_direction(direction));
    let sun_cube = in_cloud.light_dims.w != 0u;
    // The sky's direct light scattered towards the camera, the
    // transmittance taken as a cap of open sky of its orders ≤ 1
    // (cumulus::interior::SkyDirectKernel).
    let sky_direct_weight = in_cloud.light_min.w;
    var sky_kernel: SkyDirectKernel;
    if (sky_direct_weight > 0.0) {
        sky_kernel = sky_direct_kernel(stratus_layered_lighting(clouds_lighting(lighting), under).sh, asymmetry, -direction);
    }
    var sun_segments: array<vec4<f32>, IN_CLOUD_SHADOW_SEGMENTS>;
    var sun_lobes: array<f32, IN_CLOUD_SHADOW_SEGMENTS>;
    var layer_shadows: array<vec3<f32>, IN_CLOUD_SHADOW_SEGMENTS>;
    // For the forward peak: the optical depth (δ-M) the sun's path crosses
    // in this cloud to each segment's middle, and the shadow of all else.
    var own_depths: array<f32, IN_CLOUD_SHADOW_SEGMENTS>;
    var other_shadows: array<f32, IN_CLOUD_SHADOW_SEGMENTS>;
    var beyond = 1.0;
    for (var k = 0u; k < IN_CLOUD_SHADOW_SEGMENTS; k += 1u) {
        let f = (f32(k) + 0.5) / f32(IN_CLOUD_SHADOW_SEGMENTS);
        let p = origin_m + direction * (t0 + (t1 - t0) * f * f);
        own_depths[k] = 0.0;
        if (cumulus_term_on(CUMULUS_SHADOW)) {
            let own = in_cloud_own_depth(in_cloud_object(p), object_sun);
            if ((k & 1u) == 0u) {
                beyond = in_cloud_beyond_transmittance(own.xyz);
            }
            own_depths[k] = own.w;
        }
        other_shadows[k] = beyond * stratus_sun_transmittance(p).g * terrain_sun_visibility(p);
        let direct = exp(-own_depths[k]) * other_shadows[k];
        // The layer's and the terrain's shadow on the multiply scattered
        // sunlight, at every other point (it varies over the layer's cells).
        if (!stratus_enabled() && terrain_shadow.square.y == 0.0) {
            layer_shadows[k] = vec3<f32>(1.0);
        } else if ((k & 1u) == 0u) {
            layer_shadows[k] = in_cloud_layer_shadow(p);
        } else {
            layer_shadows[k] = layer_shadows[k - 1u];
        }
        sun_segments[k] = vec4<f32>(PI * cumulus_sun_radiance(p.y), direct);
        let depth = -log(max(direct, 1e-8));
        if (sun_cube) {
            // How the sun cube's excess along the beam spreads towards the
            // camera here (cumulus::interior::sun_cube_excess_shape), at
            // every other point (eight lobes each; the beam's depth varies
            // slowly along the ray).
            if ((k & 1u) == 0u) {
                sun_lobes[k] = sun_cube_excess_shape(toward_camera, -object_sun_unit, depth, asymmetry);
            } else {
                sun_lobes[k] = sun_lobes[k - 1u];
            }
        } else {
            sun_lobes[k] = forward_orders_lobe(depth, dot(direction, l), asymmetry);
        }
    }
    var out: InCloudMarch;
    out.radiance = vec3<f32>(0.0);
    out.transmittance = 1.0;
    out.opaque_t = -1.0;
    var weighted = vec3<f32>(0.0);
    var weight = 0.0;
    var optical_depth = 0.0;
    // The sun's light scattered only within the droplets' forward peak,
    // which δ-M keeps in the beam and so the source above never sees: the
    // silver lining of a cloud seen near the sun. At each point the peak's
    // source by the last scattering H(θ, τ_sun) (forward_peak's notes) of
    // the beam that has crossed τ_sun of this cloud on the sun's own path
    // to it (the segments' depths, linear between their middles), seen
    // through the view's whole optical depth τ (no δ-M: whatever scatters
    // after is counted where it last scatters). Along a chord straight
    // towards the sun this is F(θ, τ) of the chord, the mesh's term; on a
    // rim whose beam comes through the body behind it, less.
    let angle = acos(clamp(dot(direction, l), -1.0, 1.0));
    let peak_on = angle < cumulus.peak_grid.x && cumulus.extension.y > 0.0;
    var peak = vec3<f32>(0.0);
    let span = t1 - t0;
    for (var i = 0u; i < steps; i += 1u) {
        let a = f32(i) / f32(steps);
        let b = f32(i + 1u) / f32(steps);
        let dt = span * (b * b - a * a);
        let t = t0 + span * 0.5 * (a * a + b * b);
        let p = origin_m + direction * t;
        let object = in_cloud_object(p);
        let sigma = in_cloud_sigma(object);
        if (sigma <= 0.0) {
            continue;
        }
        let texel = in_cloud_light_texel(object);
        let light = in_cloud_light_at(texel, 0.0);
        let segment = min(i * IN_CLOUD_SHADOW_SEGMENTS / steps, IN_CLOUD_SHADOW_SEGMENTS - 1u);
        let sun = sun_segments[segment];
        var environment = light.rgb;
        var flux_ground = vec4<f32>(0.0);
        if (sky_direct_weight > 0.0 || under.under) {
            flux_ground = in_cloud_light_at(texel, 2.0);
        }
        if (sky_direct_weight > 0.0) {
            // Eddington's (Φ + 3 g* o·F)/(4π): the sky's scattered light
            // flows out through the faces (cumulus::interior's notes).
            let toward = 3.0 * asymmetry * dot(-direction, flux_ground.xyz) / max(dot(light.rgb, luma), 1e-6);
            environment *= max(1.0 + sky_direct_weight * toward, 0.0);
        }
        if (under.under) {
            environment = max(under.sky_scale * dot(environment, luma) + under.ground_add * flux_ground.w, vec3<f32>(0.0));
        }
        // The sun's scattered light towards the camera: from the sun cube
        // and its excess along the beam; until it is ready, what left the
        // beam, 1 − T, in the forward lobe, the rest isotropic
        // (cumulus::interior's notes).
        var sun_toward = vec3<f32>(0.0);
        if (sun_cube) {
            sun_toward = layer_shadows[segment] * in_cloud_sun_toward(object, toward_camera, sun_lobes[segment]);
        } else {
            let sun_fluence = layer_shadows[segment] * light.a;
            let forward = min(vec3<f32>(max(1.0 - sun.a, 0.0)), max(sun_fluence, vec3<f32>(0.0)));
            sun_toward = sun_fluence - forward + forward * sun_lobes[segment];
        }
        let scattered = sun.rgb * sun_toward + environment;
        var source = phase * sun.rgb * sun.a + scattered / (4.0 * PI);
        if (sky_direct_weight > 0.0) {
            let sky_direct = sky_direct_source(sky_kernel, in_cloud_light_at(texel, 1.0));
            source += sky_direct_weight * sky_direct;
        }
        let opacity = 1.0 - exp(-sigma * dt);
        if (peak_on) {
            let x = clamp((0.5 * (a + b)) * f32(IN_CLOUD_SHADOW_SEGMENTS) - 0.5, 0.0, f32(IN_CLOUD_SHADOW_SEGMENTS - 1u));
            let k0 = u32(floor(x));
            let k1 = min(k0 + 1u, IN_CLOUD_SHADOW_SEGMENTS - 1u);
            let sun_depth = mix(own_depths[k0], own_depths[k1], x - f32(k0)) / truncation;
            let step_depth = sigma * dt / truncation;
            let seen = exp(-(optical_depth / truncation + 0.5 * step_depth)) * step_depth;
            peak += seen * sun_segments[segment].rgb * other_shadows[segment]
                * cumulus_forward_peak_source(angle, sun_depth);
        }
        optical_depth += sigma * dt;
        let seen = out.transmittance * opacity;
        out.radiance += seen * source;
        weighted += seen * p;
        weight += seen;
        let before = out.transmittance;
        out.transmittance *= 1.0 - opacity;
        if (before >= 0.5 && out.transmittance < 0.5) {
            out.opaque_t = t;
        }
        // Nothing farther is seen.
        if (out.transmittance < 1e-4) {
            out.transmittance = 0.0;
            break;
        }
    }
    out.mean_m = select(origin_m, weighted / max(weight, 1e-6), weight > 0.0);
    out.radiance += cumulus.extension.y * peak;
    return out;
}

// Where a ray (object frame) enters and leaves the extinction's box.
fn in_cloud_box(origin: vec3<f32>, direction: vec3<f32>) -> vec2<f32> {
    let inverse = 1.0 / direction;
    let a = (in_cloud.extinction_min.xyz - origin) * inverse;
    let b = (in_cloud.extinction_min.xyz + in_cloud.extinction_size.xyz - origin) * inverse;
    let near = max(max(min(a.x, b.x), min(a.y, b.y)), min(a.z, b.z));
    let far = min(min(max(a.x, b.x), max(a.y, b.y)), max(a.z, b.z));
    return vec2<f32>(max(near, 0.0), far);
}

// The march of a pixel: premultiplied colour (the fade applied) and where
// the cloud became opaque (negative if it did not).
struct InCloudPixel {
    colour: vec4<f32>,
    opaque_t: f32,
}

fn in_cloud_pixel(clip_xy: vec2<f32>, pixel: vec2<i32>) -> InCloudPixel {
    var out: InCloudPixel;
    out.colour = vec4<f32>(0.0);
    out.opaque_t = -1.0;
    let direction = view_ray_world(clip_xy);
    let origin = view_ray_origin_world(clip_xy);
    let depth = textureLoad(in_cloud_scene_depth, pixel, 0).r;
    var end_m = 1e9;
    if (depth > 0.0) {
        end_m = length(world_at_depth(clip_xy, depth) - origin);
    }
    // The ray in the object frame, parametrised by world metres.
    let object_direction = in_cloud_object_direction(direction);
    let span = in_cloud_box(in_cloud_object(origin), object_direction);
    let t1 = min(span.y, end_m);
    if (t1 <= span.x) {
        return out;
    }
    // The box's empty space before the cloud skipped, in strides of 1/64
    // of the chord: the march's fine first steps and the direct beam's
    // segments then start at the cloud's face, not at the box's (from
    // outside, a face 200 m into the box met steps of ~20 m and a beam
    // held over ~60 m).
    var t0 = -1.0;
    let stride = (t1 - span.x) / f32(IN_CLOUD_SKIP_STEPS);
    for (var i = 0u; i < IN_CLOUD_SKIP_STEPS; i += 1u) {
        let t = span.x + (f32(i) + 0.5) * stride;
        if (in_cloud_sigma(in_cloud_object(origin + direction * t)) > 0.0) {
            t0 = max(span.x, t - stride);
            break;
        }
    }
    if (t0 < 0.0) {
        return out;
    }
    let march = in_cloud_march(origin, direction, t0, t1);
    let opacity = 1.0 - march.transmittance;
    if (opacity <= 0.0) {
        return out;
    }
    // The air in front of the light, at its mean depth: α f(L/α).
    let seen = opacity * stratus_apply_aerial_perspective(march.radiance / opacity, march.mean_m);
    let fade = in_cloud.rotation.z;
    out.colour = vec4<f32>(to_target(seen).rgb * fade, opacity * fade);
    out.opaque_t = march.opaque_t;
    return out;
}

@fragment
fn in_cloud_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    return in_cloud_pixel(in.clip_xy, vec2<i32>(in.position.xy)).colour;
}

struct InCloudVolumeOutput {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

// The volume model's march: the colour, and the depth of the body where
// the cloud is opaque (else the depth read: what is behind stays in front
// of whatever is drawn later).
@fragment
fn in_cloud_volume_fragment(in: FullscreenOutput) -> InCloudVolumeOutput {
    let pixel = vec2<i32>(in.position.xy);
    let march = in_cloud_pixel(in.clip_xy, pixel);
    var out: InCloudVolumeOutput;
    out.colour = march.colour;
    out.depth = textureLoad(in_cloud_scene_depth, pixel, 0).r;
    if (march.opaque_t >= 0.0) {
        let p = view_ray_origin_world(in.clip_xy) + view_ray_world(in.clip_xy) * march.opaque_t;
        let clip = frame.clip_from_world * vec4<f32>(p, 1.0);
        out.depth = max(out.depth, clamp(clip.z / clip.w, 0.0, 1.0));
    }
    return out;
}

// The depth buffer copied into the float texture the marches read.
@fragment
fn in_cloud_scene_depth_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    return vec4<f32>(textureLoad(in_cloud_depth, vec2<i32>(in.position.xy), 0), 0.0, 0.0, 0.0);
}
