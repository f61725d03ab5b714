//! The scene's settings types are `#[non_exhaustive]`: code outside the
//! crate (an embedder's) builds them from `Default` or their constructors
//! and sets fields. This file is such code: it stops compiling if a type
//! loses its way to be built, and checks what it builds is a valid scene.

use nimbus_render::Scene;
use nimbus_render::scene::{
    CumulusSettings, PlacedCloud, RainAreaSettings, RainSettings, SceneObject, WindFieldSettings,
    WindPrimitiveKindSetting, WindPrimitiveSettings, WindSettings,
};

#[test]
fn every_settings_type_can_be_built_outside_the_crate() {
    let mut scene = Scene::default();
    scene.camera.fov_deg = 50.0;

    let mut cumulus = CumulusSettings::default();
    let mut cloud = PlacedCloud::new([0.0, 1500.0, 0.0]);
    cloud.scale = 1.5;
    cumulus.clouds.push(cloud);
    scene.cumulus = Some(cumulus);

    let mut rain = RainSettings::default();
    let mut area = RainAreaSettings::new([100.0, -200.0], 800.0);
    area.edge_m = 100.0;
    rain.areas.push(area);
    scene.rain = Some(rain);

    let mut wind = WindSettings::default();
    let mut vortex = WindPrimitiveSettings::new(WindPrimitiveKindSetting::Vortex, 5.0);
    vortex.radius_m = 40.0;
    wind.primitives.push(vortex);
    scene.wind = Some(wind);

    scene.objects.push(SceneObject::new_box(
        [0.0, 10.0, 0.0],
        [4.0, 3.0, 6.0],
        0.0,
        [0.4; 3],
    ));
    scene.check().expect("a valid scene");

    // Constructors give the scene file's defaults for what they leave out.
    let text = "position_m = [0.0, 1500.0, 0.0]";
    assert_eq!(
        PlacedCloud::new([0.0, 1500.0, 0.0]),
        toml::from_str::<PlacedCloud>(text).expect("parses")
    );
    let text = "center_m = [100.0, -200.0]\nradius_m = 800.0";
    assert_eq!(
        RainAreaSettings::new([100.0, -200.0], 800.0),
        toml::from_str::<RainAreaSettings>(text).expect("parses")
    );
    let text = "kind = \"vortex\"\nspeed_m_s = 5.0";
    assert_eq!(
        WindPrimitiveSettings::new(WindPrimitiveKindSetting::Vortex, 5.0),
        toml::from_str::<WindPrimitiveSettings>(text).expect("parses")
    );
    let text = "file = \"wind.npy\"\ncell_m = 2.0";
    assert_eq!(
        WindFieldSettings::new("wind.npy", 2.0),
        toml::from_str::<WindFieldSettings>(text).expect("parses")
    );
}
