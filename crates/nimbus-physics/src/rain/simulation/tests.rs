//! Tests of the rain dynamics against measurements and the Marshall–Palmer
//! expectation.

use super::*;
use crate::rain::drag::GUNN_KINZER_1949;
use crate::rain::rain_box::RainBoxShape;
use crate::rain::wind::{WindGrid, WindPrimitive, WindPrimitiveKind};

const BASIS: [Vec3; 3] = [Vec3::X, Vec3::Y, Vec3::NEG_Z];

fn sphere(radius_m: f32, center_m: Vec3) -> RainBox {
    RainBox::at_rest(RainBoxShape::Sphere { radius_m }, center_m, BASIS)
}

fn run(simulation: &mut Simulation, seconds: f32) {
    let steps = (seconds / STEP_S).round() as u32;
    for _ in 0..steps {
        let b = simulation.rain_box;
        simulation.step(b);
    }
}

#[test]
fn drops_falling_from_rest_reach_gunn_and_kinzer_speeds() {
    let wind = WindField::default();
    let zones = RainZones::everywhere();
    let inputs = StepInputs {
        params: RainParams::default(),
        rain_box: sphere(1e6, Vec3::ZERO),
        wind: &wind,
        zones: &zones,
        time_s: 0.0,
        step: 0,
        dt_s: STEP_S,
        ground_height_m: f32::NEG_INFINITY,
    };
    for (d, measured) in GUNN_KINZER_1949
        .iter()
        .filter(|(d, _)| (0.5..=5.0).contains(d))
    {
        let mut drop = Drop {
            position_m: Vec3::ZERO,
            diameter_mm: *d as f32,
            velocity_m_s: Vec3::ZERO,
            state: DropState::Alive,
        };
        for _ in 0..(20.0 / STEP_S) as u32 {
            drop = step_drop(0, drop, &inputs).0;
        }
        let speed = -drop.velocity_m_s.y as f64;
        let error = (speed - measured).abs() / measured;
        assert!(error < 0.05, "D {d} mm: {speed:.3} vs {measured} m/s");
    }
}

#[test]
fn drops_in_a_steady_wind_move_with_it() {
    let wind = Vec3::new(9.0, 0.0, -4.0);
    let params = RainParams {
        intensity_mm_h: 10.0,
        ..RainParams::default()
    };
    let mut simulation = Simulation::new(
        params,
        WindField::uniform(wind),
        RainZones::everywhere(),
        sphere(6.0, Vec3::new(0.0, 100.0, 0.0)),
        f32::NEG_INFINITY,
    );
    run(&mut simulation, 4.0);
    let s = simulation.statistics();
    let v = Vec3::new(
        s.mean_velocity_m_s[0] as f32,
        0.0,
        s.mean_velocity_m_s[2] as f32,
    );
    let error = (v - wind).length() / wind.length();
    assert!(error < 0.02, "{v} vs {wind}");
    assert!(simulation.recycled > 0);
}

#[test]
fn drop_counts_follow_marshall_palmer_from_1_to_100_mm_h() {
    for intensity in [1.0, 5.0, 25.0, 100.0] {
        let params = RainParams {
            intensity_mm_h: intensity,
            min_diameter_mm: 1.0,
            ..RainParams::default()
        };
        let b = sphere(5.0, Vec3::new(0.0, 50.0, 0.0));
        let mut simulation = Simulation::new(
            params,
            WindField::uniform(Vec3::new(3.0, 0.0, 1.0)),
            RainZones::everywhere(),
            b,
            f32::NEG_INFINITY,
        );
        run(&mut simulation, 3.0);
        let expected = expected_drop_count(intensity, 1.0, b.volume_m3());
        let s = simulation.statistics();
        let error = (s.drops as f64 - expected).abs() / expected;
        assert!(
            error < 0.03,
            "{intensity} mm/h: {} vs {expected:.0}",
            s.drops
        );
        // Uniform filling: the inner ball of half the radius holds 1/8 of them.
        let inner = simulation
            .drops
            .iter()
            .filter(|d| d.state == DropState::Alive && (d.position_m - b.center_m).length() < 2.5)
            .count() as f64;
        let sigma = (expected / 8.0).sqrt();
        assert!(
            (inner - expected / 8.0).abs() < 5.0 * sigma + 0.02 * expected / 8.0,
            "{intensity} mm/h: inner {inner} vs {:.0}",
            expected / 8.0
        );
    }
}

#[test]
fn a_moving_camera_leaves_no_empty_region() {
    // Blanchard 2023, Fig. 33: with recycling relative to the moving box,
    // the side the camera moves towards is as full as the other.
    let params = RainParams {
        intensity_mm_h: 20.0,
        min_diameter_mm: 1.0,
        ..RainParams::default()
    };
    let velocity = Vec3::new(15.0, 0.0, 0.0);
    let mut b = sphere(6.0, Vec3::new(0.0, 60.0, 0.0));
    let mut simulation = Simulation::new(
        params,
        WindField::default(),
        RainZones::everywhere(),
        b,
        f32::NEG_INFINITY,
    );
    b.velocity_m_s = velocity;
    for _ in 0..(3.0 / STEP_S) as u32 {
        b.center_m += velocity * STEP_S;
        simulation.step(b);
    }
    let (mut ahead, mut behind) = (0.0, 0.0);
    for d in simulation
        .drops
        .iter()
        .filter(|d| d.state == DropState::Alive)
    {
        if d.position_m.x > b.center_m.x {
            ahead += 1.0;
        } else {
            behind += 1.0;
        }
    }
    let total: f64 = ahead + behind;
    assert!(
        (ahead - behind).abs() < 4.0 * total.sqrt(),
        "ahead {ahead}, behind {behind}"
    );
    let expected = expected_drop_count(20.0, 1.0, b.volume_m3());
    assert!(
        (total - expected).abs() < 0.03 * expected,
        "{total} vs {expected}"
    );
}

#[test]
fn intensity_changes_act_only_at_the_boundary() {
    let params = RainParams {
        intensity_mm_h: 2.0,
        min_diameter_mm: 1.0,
        ..RainParams::default()
    };
    let b = sphere(5.0, Vec3::new(0.0, 50.0, 0.0));
    let mut simulation = Simulation::new(
        params,
        WindField::default(),
        RainZones::everywhere(),
        b,
        f32::NEG_INFINITY,
    );
    run(&mut simulation, 1.0);
    let before = simulation.statistics().drops as f64;
    simulation.set_intensity(50.0);
    let target = expected_drop_count(50.0, 1.0, b.volume_m3());
    // One step later almost nothing has changed: no drops popped in.
    run(&mut simulation, STEP_S);
    let after_one_step = simulation.statistics().drops as f64;
    assert!(
        after_one_step - before < 0.05 * (target - before),
        "{before} → {after_one_step}"
    );
    // The box fills from upstream within a few crossing times (2R / 5 m/s ≈ 2 s).
    run(&mut simulation, 8.0);
    let later = simulation.statistics().drops as f64;
    assert!(
        (later - target).abs() < 0.05 * target,
        "{later} vs {target}"
    );
    // Back down: drops leave as they cross out, none vanish in place.
    simulation.set_intensity(2.0);
    let alive_ids: Vec<usize> = (0..simulation.drops.len())
        .filter(|&i| simulation.drops[i].state == DropState::Alive)
        .collect();
    let positions: Vec<Vec3> = alive_ids
        .iter()
        .map(|&i| simulation.drops[i].position_m)
        .collect();
    run(&mut simulation, STEP_S);
    for (&i, p) in alive_ids.iter().zip(positions) {
        let d = simulation.drops[i];
        if d.state == DropState::Dead {
            panic!("drop {i} died inside the box at {p}");
        }
    }
}

#[test]
fn drops_stop_on_the_ground_and_splash() {
    let params = RainParams {
        intensity_mm_h: 10.0,
        min_diameter_mm: 1.0,
        ..RainParams::default()
    };
    let b = sphere(6.0, Vec3::new(0.0, 2.0, 0.0));
    let mut simulation = Simulation::new(
        params,
        WindField::uniform(Vec3::new(5.0, 0.0, 0.0)),
        RainZones::everywhere(),
        b,
        0.0,
    );
    run(&mut simulation, 3.0);
    assert!(simulation.splashes > 100);
    for d in &simulation.drops {
        if matches!(d.state, DropState::Alive) {
            assert!(d.position_m.y >= 0.0, "{:?}", d);
        }
    }
    // The density is Marshall–Palmer's above the ground and zero below:
    // the drops drawn are those of the cap above the ground (height R + 2).
    let s = simulation.statistics();
    let h = 8.0f64;
    let above = std::f64::consts::PI * h * h * (3.0 * 6.0 - h) / 3.0;
    let expected = expected_drop_count(10.0, 1.0, b.volume_m3()) * above / b.volume_m3() as f64;
    println!("{} drops above the ground, {expected:.0} expected", s.drops);
    // 0.25 % here. (This was 3.1 % low while drops entering under cover
    // died instead of becoming ghosts, unlike the GPU's: dead drops come
    // back only at the inflow rate, so the box held too few.)
    assert!(
        (s.drops as f64 - expected).abs() < 0.01 * expected,
        "{} vs {expected:.0}",
        s.drops
    );
}

#[test]
fn ten_minutes_of_gusty_wind_stay_finite() {
    let wind = WindField {
        mean_m_s: Vec3::new(6.0, 0.0, 2.0),
        grid: Some(WindGrid::turbulence(16, 64.0, 3.0, 4)),
        primitives: vec![
            WindPrimitive {
                kind: WindPrimitiveKind::GustFront,
                center_m: Vec3::ZERO,
                drift_m_s: Vec3::ZERO,
                axis: Vec3::X,
                speed_m_s: 15.0,
                radius_m: 30.0,
                period_s: 40.0,
                front_speed_m_s: 12.0,
            },
            WindPrimitive {
                kind: WindPrimitiveKind::Vortex,
                center_m: Vec3::new(4.0, 0.0, 0.0),
                drift_m_s: Vec3::new(1.0, 0.0, 0.0),
                axis: Vec3::Y,
                speed_m_s: 20.0,
                radius_m: 3.0,
                period_s: 0.0,
                front_speed_m_s: 0.0,
            },
            WindPrimitive {
                kind: WindPrimitiveKind::Source,
                center_m: Vec3::new(0.0, 40.0, 0.0),
                drift_m_s: Vec3::ZERO,
                axis: Vec3::Y,
                speed_m_s: -10.0,
                radius_m: 2.0,
                period_s: 0.0,
                front_speed_m_s: 0.0,
            },
        ],
    };
    let params = RainParams {
        intensity_mm_h: 30.0,
        max_drops: 1500,
        ..RainParams::default()
    };
    let mut simulation = Simulation::new(
        params,
        wind,
        RainZones::everywhere(),
        sphere(4.0, Vec3::new(0.0, 40.0, 0.0)),
        38.0,
    );
    run(&mut simulation, 600.0);
    let s = simulation.statistics();
    assert_eq!(s.non_finite_values, 0);
    assert!(s.drops > 1000, "{}", s.drops);
}
