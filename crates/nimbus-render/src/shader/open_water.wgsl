// import shader/lit_surface.wgsl
// import shader/water.wgsl
// Open water under nimbus's clouds: water.wgsl's two hooks for water that
// the sky, the stratus layer and the cumulus shadows light, so that the
// terrain's lakes and coast (the terrain pass) and the open sea beyond the
// terrain's edge (the sky pass) are shaded alike.

// What the water reflects: the sky, behind the stratus layer where the
// reflected ray meets it (the layer's base then seen with its opacity
// 1 − τ and, as its radiance, the overcast hemisphere's mean radiance R_G/π
// in the deck's angular shape, stratus_deck_light_shape: a grazing
// reflection sees the deck near the horizon), faded with the layer towards
// its window's edge as the camera sees it.
fn water_reflection_source(position_m: vec3<f32>, direction: vec3<f32>) -> vec3<f32> {
    let sky = sky_radiance(direction);
    if (!stratus_enabled() || position_m.y >= stratus.window.x || direction.y <= 1e-3) {
        return sky;
    }
    let crossing = position_m.xz + direction.xz * ((stratus.window.x - position_m.y) / direction.y);
    let fade = stratus_window_fade(crossing);
    if (fade <= 0.0) {
        // Beyond the window, where no layer is drawn (and where its
        // thickness would be the field evaluated, not looked up).
        return sky;
    }
    let h = stratus_thickness_at(crossing);
    let opacity = (1.0 - exp(-stratus.extinction.y * h / direction.y)) * fade;
    let shape = stratus_deck_light_shape();
    let base = stratus_radiosity_sample(true, crossing) / PI * (shape.x + shape.y * direction.y);
    return mix(sky, base, opacity);
}

// The diffuse irradiance on the horizontal water surface: the clear sky's,
// or under the layer the radiosity's R_G.
fn water_sky_irradiance(position_m: vec3<f32>) -> vec3<f32> {
    let up = vec3<f32>(0.0, 1.0, 0.0);
    return stratus_ground_irradiance(position_m, up, lighting.sky_irradiance_up.xyz);
}
