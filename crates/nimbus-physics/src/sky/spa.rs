//! Solar position from date, time and place: the NREL Solar Position
//! Algorithm (SPA), accurate to ±0.0003° for years −2000 to 6000.
//!
//! Reference: Reda & Andreas, "Solar Position Algorithm for Solar Radiation
//! Applications", NREL/TP-560-34302, 2004 (revised 2008); section and
//! equation numbers below are that report's. Angles in degrees; time in UTC
//! (UT1 − UTC, below 0.9 s, is neglected: at most 0.004° of hour angle);
//! ΔT = TT − UT from Espenak & Meeus's polynomials (NASA, "Polynomial
//! expressions for Delta T", 2006), which only enters the slowly varying
//! ephemeris time, so a 2 s error in it moves the sun by 2·10⁻⁵°.
//!
//! Output: the topocentric zenith angle without refraction (eq. 41 with
//! Δe = 0), the apparent one with the refraction of eq. 42, and the azimuth
//! measured clockwise from north (eq. 45), as nimbus's sun angles use.

use super::spa_tables::{B_TERMS, L_TERMS, NUTATION_TERMS, R_TERMS};
use super::time::UtcDateTime;

/// Where the sun is seen from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observer {
    /// Geodetic latitude, degrees north, in [−90, 90].
    pub latitude_deg: f64,
    /// Longitude, degrees east of Greenwich, in [−180, 180].
    pub longitude_deg: f64,
    /// Height above sea level, m.
    pub elevation_m: f64,
    /// Annual mean air pressure, mbar (for refraction only).
    pub pressure_mbar: f64,
    /// Annual mean air temperature, °C (for refraction only).
    pub temperature_c: f64,
}

impl Observer {
    /// An observer at sea level in a standard atmosphere (1013.25 mbar, 15 °C).
    pub fn at(latitude_deg: f64, longitude_deg: f64) -> Self {
        Self {
            latitude_deg,
            longitude_deg,
            elevation_m: 0.0,
            pressure_mbar: 1013.25,
            temperature_c: 15.0,
        }
    }
}

/// The sun's topocentric position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolarPosition {
    /// Topocentric zenith angle without refraction, degrees.
    pub zenith_deg: f64,
    /// Topocentric zenith angle with atmospheric refraction, degrees.
    pub apparent_zenith_deg: f64,
    /// Topocentric azimuth, degrees clockwise from north, in [0, 360).
    pub azimuth_deg: f64,
    /// Julian day (UT).
    pub julian_day: f64,
    /// Geocentric declination, degrees.
    pub declination_deg: f64,
    /// Geocentric right ascension, degrees.
    pub right_ascension_deg: f64,
    /// Earth–sun distance, astronomical units.
    pub radius_au: f64,
}

impl SolarPosition {
    /// Elevation above the horizon without refraction, degrees.
    pub fn elevation_deg(&self) -> f64 {
        90.0 - self.zenith_deg
    }
}

/// ΔT = TT − UT in seconds for a decimal year (Espenak & Meeus 2006).
pub fn delta_t_s(year: f64) -> f64 {
    if year < 2005.0 {
        // 1986–2005.
        let t = year - 2000.0;
        63.86 + 0.3345 * t - 0.060374 * t * t
            + 0.0017275 * t.powi(3)
            + 0.000651814 * t.powi(4)
            + 0.00002373599 * t.powi(5)
    } else if year < 2050.0 {
        let t = year - 2000.0;
        62.92 + 0.32217 * t + 0.005589 * t * t
    } else {
        // 2050–2150.
        -20.0 + 32.0 * ((year - 1820.0) / 100.0).powi(2) - 0.5628 * (2150.0 - year)
    }
}

/// Julian day of a UTC date-time (SPA eq. 4, Gregorian calendar).
pub fn julian_day(t: &UtcDateTime) -> f64 {
    let (mut y, mut m) = (t.year as f64, t.month as f64);
    if m <= 2.0 {
        y -= 1.0;
        m += 12.0;
    }
    let day = t.day as f64 + (t.hour as f64 + (t.minute as f64 + t.second / 60.0) / 60.0) / 24.0;
    let a = (y / 100.0).floor();
    let b = 2.0 - a + (a / 4.0).floor();
    (365.25 * (y + 4716.0)).floor() + (30.6001 * (m + 1.0)).floor() + day + b - 1524.5
}

fn limit_degrees(x: f64) -> f64 {
    x.rem_euclid(360.0)
}

/// Σ over the term groups of JME^i Σ A cos(B + C·JME) (eqs. 9–11).
fn periodic_sum(groups: &[&[[f64; 3]]], jme: f64) -> f64 {
    groups
        .iter()
        .enumerate()
        .map(|(i, terms)| {
            terms
                .iter()
                .map(|[a, b, c]| a * (b + c * jme).cos())
                .sum::<f64>()
                * jme.powi(i as i32)
        })
        .sum::<f64>()
        / 1e8
}

/// The SPA with an explicit ΔT (seconds).
pub fn solar_position_with_delta_t(
    time: &UtcDateTime,
    observer: &Observer,
    delta_t: f64,
) -> SolarPosition {
    let (sin, cos) = (|d: f64| d.to_radians().sin(), |d: f64| d.to_radians().cos());
    // 3.1 Julian day, ephemeris day, centuries and millennia.
    let jd = julian_day(time);
    let jde = jd + delta_t / 86400.0;
    let jc = (jd - 2451545.0) / 36525.0;
    let jce = (jde - 2451545.0) / 36525.0;
    let jme = jce / 10.0;

    // 3.2 Earth heliocentric longitude, latitude (degrees) and radius vector (AU).
    let l = limit_degrees(periodic_sum(&L_TERMS, jme).to_degrees());
    let b = periodic_sum(&B_TERMS, jme).to_degrees();
    let r = periodic_sum(&R_TERMS, jme);

    // 3.3 Geocentric longitude and latitude.
    let theta = limit_degrees(l + 180.0);
    let beta = -b;

    // 3.4 Nutation in longitude and obliquity (eqs. 15–23).
    let x = [
        297.85036 + 445267.111480 * jce - 0.0019142 * jce * jce + jce.powi(3) / 189474.0,
        357.52772 + 35999.050340 * jce - 0.0001603 * jce * jce - jce.powi(3) / 300000.0,
        134.96298 + 477198.867398 * jce + 0.0086972 * jce * jce + jce.powi(3) / 56250.0,
        93.27191 + 483202.017538 * jce - 0.0036825 * jce * jce + jce.powi(3) / 327270.0,
        125.04452 - 1934.136261 * jce + 0.0020708 * jce * jce + jce.powi(3) / 450000.0,
    ];
    let (mut delta_psi, mut delta_epsilon) = (0.0, 0.0);
    for (y, [a, bb, c, d]) in NUTATION_TERMS.iter() {
        let arg: f64 = (0..5).map(|j| x[j] * y[j] as f64).sum();
        delta_psi += (a + bb * jce) * sin(arg);
        delta_epsilon += (c + d * jce) * cos(arg);
    }
    delta_psi /= 36_000_000.0;
    delta_epsilon /= 36_000_000.0;

    // 3.5 True obliquity of the ecliptic (eqs. 24–25).
    let u = jme / 10.0;
    let epsilon0 = [
        84381.448, -4680.93, -1.55, 1999.25, -51.38, -249.67, -39.05, 7.12, 27.87, 5.79, 2.45,
    ]
    .iter()
    .enumerate()
    .map(|(k, c)| c * u.powi(k as i32))
    .sum::<f64>();
    let epsilon = epsilon0 / 3600.0 + delta_epsilon;

    // 3.6–3.7 Aberration and apparent sun longitude.
    let delta_tau = -20.4898 / (3600.0 * r);
    let lambda = theta + delta_psi + delta_tau;

    // 3.8 Apparent sidereal time at Greenwich.
    let nu0 = limit_degrees(
        280.46061837 + 360.98564736629 * (jd - 2451545.0) + 0.000387933 * jc * jc
            - jc.powi(3) / 38710000.0,
    );
    let nu = nu0 + delta_psi * cos(epsilon);

    // 3.9–3.10 Geocentric right ascension and declination.
    let alpha = limit_degrees(
        (sin(lambda) * cos(epsilon) - beta.to_radians().tan() * sin(epsilon))
            .atan2(cos(lambda))
            .to_degrees(),
    );
    let delta = (sin(beta) * cos(epsilon) + cos(beta) * sin(epsilon) * sin(lambda))
        .asin()
        .to_degrees();

    // 3.11 Observer local hour angle.
    let phi = observer.latitude_deg;
    let h = limit_degrees(nu + observer.longitude_deg - alpha);

    // 3.12 Topocentric right ascension and declination (parallax).
    let xi = 8.794 / (3600.0 * r);
    let u_lat = (0.99664719 * phi.to_radians().tan()).atan().to_degrees();
    let x_p = cos(u_lat) + observer.elevation_m / 6378140.0 * cos(phi);
    let y_p = 0.99664719 * sin(u_lat) + observer.elevation_m / 6378140.0 * sin(phi);
    let delta_alpha = (-x_p * sin(xi) * sin(h))
        .atan2(cos(delta) - x_p * sin(xi) * cos(h))
        .to_degrees();
    let delta_prime = ((sin(delta) - y_p * sin(xi)) * cos(delta_alpha))
        .atan2(cos(delta) - x_p * sin(xi) * cos(h))
        .to_degrees();

    // 3.13 Topocentric local hour angle.
    let h_prime = h - delta_alpha;

    // 3.14 Topocentric elevation and zenith, with and without refraction (eqs. 41–44).
    let e0 = (sin(phi) * sin(delta_prime) + cos(phi) * cos(delta_prime) * cos(h_prime))
        .asin()
        .to_degrees();
    let sun_radius_deg = 0.26667;
    let refraction_at_horizon_deg = 0.5667;
    let delta_e = if e0 >= -(sun_radius_deg + refraction_at_horizon_deg) {
        (observer.pressure_mbar / 1010.0) * (283.0 / (273.0 + observer.temperature_c)) * 1.02
            / (60.0 * (e0 + 10.3 / (e0 + 5.11)).to_radians().tan())
    } else {
        0.0
    };

    // 3.15 Topocentric azimuth, eastward from north (eqs. 45–46).
    let gamma = sin(h_prime)
        .atan2(cos(h_prime) * sin(phi) - delta_prime.to_radians().tan() * cos(phi))
        .to_degrees();
    let azimuth = limit_degrees(gamma + 180.0);

    SolarPosition {
        zenith_deg: 90.0 - e0,
        apparent_zenith_deg: 90.0 - (e0 + delta_e),
        azimuth_deg: azimuth,
        julian_day: jd,
        declination_deg: delta,
        right_ascension_deg: alpha,
        radius_au: r,
    }
}

/// The SPA with ΔT from [`delta_t_s`].
pub fn solar_position(time: &UtcDateTime, observer: &Observer) -> SolarPosition {
    solar_position_with_delta_t(time, observer, delta_t_s(time.decimal_year()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The worked example of Reda & Andreas (2008), table A5.1:
    /// 17 October 2003, 12:30:30 local time at UTC−7, Golden, Colorado.
    fn example() -> (UtcDateTime, Observer) {
        let time = UtcDateTime::parse("2003-10-17T12:30:30-07:00").expect("time");
        let observer = Observer {
            latitude_deg: 39.742476,
            longitude_deg: -105.1786,
            elevation_m: 1830.14,
            pressure_mbar: 820.0,
            temperature_c: 11.0,
        };
        (time, observer)
    }

    #[test]
    fn reproduces_the_reports_worked_example() {
        let (time, observer) = example();
        let p = solar_position_with_delta_t(&time, &observer, 67.0);
        // Table A5.1: JD 2452930.312847, R 0.9965422974 AU, α 202.22741°,
        // δ −9.31434°, topocentric zenith (refracted) 50.11162°, azimuth 194.34024°.
        assert!(
            (p.julian_day - 2452930.312847).abs() < 1e-6,
            "JD {}",
            p.julian_day
        );
        assert!(
            (p.radius_au - 0.9965422974).abs() < 1e-9,
            "R {}",
            p.radius_au
        );
        assert!(
            (p.right_ascension_deg - 202.22741).abs() < 1e-5,
            "α {}",
            p.right_ascension_deg
        );
        assert!(
            (p.declination_deg + 9.31434).abs() < 1e-5,
            "δ {}",
            p.declination_deg
        );
        assert!(
            (p.apparent_zenith_deg - 50.11162).abs() < 1e-5,
            "zenith {}",
            p.apparent_zenith_deg
        );
        assert!(
            (p.azimuth_deg - 194.34024).abs() < 1e-5,
            "azimuth {}",
            p.azimuth_deg
        );
        // Refraction at 40° elevation is about 1′ at 820 mbar.
        let refraction = p.zenith_deg - p.apparent_zenith_deg;
        assert!(
            (0.01..0.02).contains(&refraction),
            "refraction {refraction}"
        );
    }

    #[test]
    fn delta_t_matches_observed_values() {
        // IERS/USNO observed ΔT: 63.83 s (2000.0), 66.07 s (2010.0); the
        // polynomial's 2020 value (71.6 s) exceeds the observed 69.36 s, an
        // error that moves the sun by only 3·10⁻⁵°.
        assert!((delta_t_s(2000.0) - 63.83).abs() < 0.1);
        assert!((delta_t_s(2010.0) - 66.07).abs() < 0.7);
        assert!((delta_t_s(2020.0) - 69.36).abs() < 2.5);
    }

    #[test]
    fn equinox_noon_and_solstice_geometry() {
        // Around the March 2024 equinox (20 March 03:06 UTC) the declination crosses zero.
        let t = UtcDateTime::parse("2024-03-20T03:06:00Z").expect("time");
        let p = solar_position(&t, &Observer::at(0.0, 0.0));
        assert!(p.declination_deg.abs() < 0.01, "δ {}", p.declination_deg);
        // At the June 2024 solstice (20 June 20:51 UTC) the declination is the obliquity, 23.44°.
        let t = UtcDateTime::parse("2024-06-20T20:51:00Z").expect("time");
        let p = solar_position(&t, &Observer::at(0.0, 0.0));
        assert!(
            (p.declination_deg - 23.44).abs() < 0.01,
            "δ {}",
            p.declination_deg
        );
        // Local solar noon at the Greenwich meridian on that day: the sun is due south
        // at zenith |51.48° − 23.44°| from the Royal Observatory.
        let t = UtcDateTime::parse("2024-06-20T12:01:40Z").expect("time");
        let p = solar_position(&t, &Observer::at(51.4778, 0.0));
        assert!(
            (p.azimuth_deg - 180.0).abs() < 0.3,
            "azimuth {}",
            p.azimuth_deg
        );
        assert!(
            (p.zenith_deg - (51.4778 - 23.44)).abs() < 0.02,
            "zenith {}",
            p.zenith_deg
        );
    }
}
