//! `nimbus sun`: the sun's position for a date, time and place (NREL SPA).

use clap::Args;
use nimbus_physics::sky::{Observer, UtcDateTime, delta_t_s, solar_position};
use serde::Serialize;

/// Arguments of `nimbus sun`.
#[derive(Debug, Args)]
pub struct SunArgs {
    /// Latitude, degrees north, in [−90, 90].
    #[arg(
        long,
        visible_alias = "latitude-deg",
        value_name = "DEG",
        allow_negative_numbers = true
    )]
    lat: f64,
    /// Longitude, degrees east, in [−180, 180].
    #[arg(
        long,
        visible_alias = "longitude-deg",
        value_name = "DEG",
        allow_negative_numbers = true
    )]
    lon: f64,
    /// Date and time, ISO 8601 with a zone: 2026-06-21T12:00:00Z or 2026-06-21T14:00:00+02:00.
    #[arg(long, value_name = "ISO8601")]
    time: String,
    /// Observer's height above sea level, m (for parallax).
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "M",
        allow_negative_numbers = true
    )]
    elevation_m: f64,
    /// Print one JSON document on standard output.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Serialize)]
struct Report {
    /// Topocentric zenith angle without refraction, degrees.
    zenith_deg: f64,
    /// Azimuth, degrees clockwise from north.
    azimuth_deg: f64,
    /// Elevation above the horizon without refraction, degrees.
    elevation_deg: f64,
    /// Zenith angle with standard atmospheric refraction, degrees.
    apparent_zenith_deg: f64,
    /// The time in UTC.
    time_utc: String,
    /// Julian day (UT).
    julian_day: f64,
    /// ΔT = TT − UT used, s.
    delta_t_s: f64,
}

fn check(name: &str, value: f64, lo: f64, hi: f64) -> anyhow::Result<()> {
    anyhow::ensure!(
        value.is_finite() && (lo..=hi).contains(&value),
        "--{name} {value}: must be a finite number in [{lo}, {hi}]"
    );
    Ok(())
}

/// Runs the subcommand.
pub fn run(args: &SunArgs) -> anyhow::Result<()> {
    check("lat", args.lat, -90.0, 90.0)?;
    check("lon", args.lon, -180.0, 180.0)?;
    check("elevation-m", args.elevation_m, -500.0, 100_000.0)?;
    let time = UtcDateTime::parse(&args.time).map_err(|e| anyhow::anyhow!("--time {e}"))?;
    let observer = Observer {
        elevation_m: args.elevation_m,
        ..Observer::at(args.lat, args.lon)
    };
    let p = solar_position(&time, &observer);
    let report = Report {
        zenith_deg: p.zenith_deg,
        azimuth_deg: p.azimuth_deg,
        elevation_deg: p.elevation_deg(),
        apparent_zenith_deg: p.apparent_zenith_deg,
        time_utc: time.to_string(),
        julian_day: p.julian_day,
        delta_t_s: delta_t_s(time.decimal_year()),
    };
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        outln!("time      {}", report.time_utc);
        outln!(
            "zenith    {:.5}°  (apparent, with refraction: {:.5}°)",
            report.zenith_deg,
            report.apparent_zenith_deg
        );
        outln!("elevation {:.5}°", report.elevation_deg);
        outln!(
            "azimuth   {:.5}°  (clockwise from north)",
            report.azimuth_deg
        );
    }
    Ok(())
}
