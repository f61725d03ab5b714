//! UTC date-times parsed from ISO 8601 / RFC 3339 text
//! (`2026-06-21T12:00:00Z`, `2003-10-17T12:30:30-07:00`, fractional seconds
//! allowed), converted to UTC.

/// A date and time in UTC (proleptic Gregorian calendar).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UtcDateTime {
    /// Year.
    pub year: i32,
    /// Month, 1–12.
    pub month: u32,
    /// Day of the month, 1–31.
    pub day: u32,
    /// Hour, 0–23.
    pub hour: u32,
    /// Minute, 0–59.
    pub minute: u32,
    /// Second, [0, 61) (leap seconds allowed).
    pub second: f64,
}

fn is_leap(year: i32) -> bool {
    (year % 4 == 0 && year % 100 != 0) || year % 400 == 0
}

fn days_in_month(year: i32, month: u32) -> u32 {
    match month {
        4 | 6 | 9 | 11 => 30,
        2 if is_leap(year) => 29,
        2 => 28,
        _ => 31,
    }
}

/// Days since 1970-01-01 of a civil date (Hinnant's algorithm).
fn days_from_civil(year: i32, month: u32, day: u32) -> i64 {
    let y = year as i64 - i64::from(month <= 2);
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let m = month as i64;
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + day as i64 - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146097 + doe - 719468
}

fn civil_from_days(z: i64) -> (i32, u32, u32) {
    let z = z + 719468;
    let era = z.div_euclid(146097);
    let doe = z - era * 146097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let year = (yoe + era * 400 + i64::from(month <= 2)) as i32;
    (year, month, day)
}

impl UtcDateTime {
    /// Parses `YYYY-MM-DDTHH:MM:SS[.fff](Z|±HH:MM)`; the zone is required.
    pub fn parse(text: &str) -> Result<Self, String> {
        let shown = crate::io::shown_text(text, crate::io::MAX_SHOWN_CHARS);
        let bad = || {
            format!(
                "`{shown}` is not a date-time like 2026-06-21T12:00:00Z (ISO 8601, with Z or a ±HH:MM offset)"
            )
        };
        let (date, rest) = text.split_once(['T', 't', ' ']).ok_or_else(bad)?;
        let mut date_parts = date.split('-');
        let (y, mo, d) = (date_parts.next(), date_parts.next(), date_parts.next());
        if date_parts.next().is_some() || date.len() != 10 {
            return Err(bad());
        }
        let number = |s: Option<&str>| s.and_then(|s| s.parse::<u32>().ok()).ok_or_else(bad);
        let (year, month, day) = (number(y)? as i32, number(mo)?, number(d)?);
        let (clock, offset_min) = if let Some(clock) = rest.strip_suffix(['Z', 'z']) {
            (clock, 0i64)
        } else {
            let split = rest.rfind(['+', '-']).ok_or_else(bad)?;
            let (clock, zone) = rest.split_at(split);
            let sign = if zone.starts_with('-') { -1 } else { 1 };
            let (hh, mm) = zone[1..].split_once(':').ok_or_else(bad)?;
            let (hh, mm) = (number(Some(hh))? as i64, number(Some(mm))? as i64);
            if hh > 23 || mm > 59 {
                return Err(bad());
            }
            (clock, sign * (hh * 60 + mm))
        };
        let mut clock_parts = clock.split(':');
        let (h, mi, s) = (clock_parts.next(), clock_parts.next(), clock_parts.next());
        if clock_parts.next().is_some() {
            return Err(bad());
        }
        let (hour, minute) = (number(h)?, number(mi)?);
        let second: f64 = s
            .and_then(|s| s.parse().ok())
            .filter(|s: &f64| s.is_finite())
            .ok_or_else(bad)?;
        if !(1..=12).contains(&month)
            || day == 0
            || day > days_in_month(year, month)
            || hour > 23
            || minute > 59
            || !(0.0..61.0).contains(&second)
        {
            return Err(format!("`{shown}`: no such date or time"));
        }
        // Shift to UTC through whole minutes; the seconds are unaffected.
        let total_min = days_from_civil(year, month, day) * 1440 + hour as i64 * 60 + minute as i64
            - offset_min;
        Ok(Self::from_minutes(total_min, second))
    }

    /// The date-time `total_min` whole minutes after the epoch plus `second`.
    fn from_minutes(total_min: i64, second: f64) -> Self {
        let (days, minute_of_day) = (total_min.div_euclid(1440), total_min.rem_euclid(1440));
        let (year, month, day) = civil_from_days(days);
        Self {
            year,
            month,
            day,
            hour: (minute_of_day / 60) as u32,
            minute: (minute_of_day % 60) as u32,
            second,
        }
    }

    /// Seconds since 1970-01-01T00:00:00Z (leap seconds not counted).
    pub fn unix_seconds(&self) -> f64 {
        let days = days_from_civil(self.year, self.month, self.day);
        (days * 86_400 + self.hour as i64 * 3600 + self.minute as i64 * 60) as f64 + self.second
    }

    /// The date-time `seconds` after 1970-01-01T00:00:00Z.
    pub fn from_unix_seconds(seconds: f64) -> Self {
        let whole_minutes = (seconds / 60.0).floor();
        let second = (seconds - whole_minutes * 60.0).clamp(0.0, 59.999_999);
        Self::from_minutes(whole_minutes as i64, second)
    }

    /// The year with its elapsed fraction (for ΔT).
    pub fn decimal_year(&self) -> f64 {
        let start = days_from_civil(self.year, 1, 1);
        let length = if is_leap(self.year) { 366.0 } else { 365.0 };
        let day = (days_from_civil(self.year, self.month, self.day) - start) as f64;
        self.year as f64
            + (day
                + (self.hour as f64 * 3600.0 + self.minute as f64 * 60.0 + self.second) / 86400.0)
                / length
    }
}

impl std::fmt::Display for UtcDateTime {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:04}-{:02}-{:02}T{:02}:{:02}:{:06.3}Z",
            self.year, self.month, self.day, self.hour, self.minute, self.second
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_zones_and_rolls_over_days() {
        let t = UtcDateTime::parse("2003-10-17T12:30:30-07:00").expect("parse");
        assert_eq!(
            (t.year, t.month, t.day, t.hour, t.minute, t.second),
            (2003, 10, 17, 19, 30, 30.0)
        );
        let t = UtcDateTime::parse("2024-01-01T01:00:00+02:00").expect("parse");
        assert_eq!((t.year, t.month, t.day, t.hour), (2023, 12, 31, 23));
        let t = UtcDateTime::parse("2024-02-29T23:59:59.5Z").expect("parse");
        assert_eq!((t.month, t.day, t.second), (2, 29, 59.5));
    }

    #[test]
    fn unix_seconds_round_trip() {
        // 2000-01-01T12:00:00Z is 946 728 000 s after the epoch.
        let t = UtcDateTime::parse("2000-01-01T12:00:00Z").expect("parse");
        assert_eq!(t.unix_seconds(), 946_728_000.0);
        let t = UtcDateTime::parse("2024-02-29T23:59:59.5Z").expect("parse");
        let back = UtcDateTime::from_unix_seconds(t.unix_seconds());
        assert_eq!(back, t);
        assert_eq!(UtcDateTime::parse(&back.to_string()).expect("parse"), t);
    }

    #[test]
    fn rejects_malformed_and_impossible_dates() {
        for text in [
            "2026-06-21",
            "2026-06-21T12:00:00",
            "2026-13-01T00:00:00Z",
            "2023-02-29T00:00:00Z",
            "2026-06-21T24:00:00Z",
            "noon",
            "2026-06-21T12:00:nanZ",
        ] {
            assert!(UtcDateTime::parse(text).is_err(), "{text}");
        }
    }

    #[test]
    fn decimal_year_runs_through_the_year() {
        let t = UtcDateTime::parse("2026-07-02T12:00:00Z").expect("parse");
        assert!((t.decimal_year() - 2026.5).abs() < 0.002);
    }
}
