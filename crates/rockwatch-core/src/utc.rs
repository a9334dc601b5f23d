//! UTC instants as integer nanoseconds since 1970-01-01T00:00:00Z, and their ISO 8601 text.
//!
//! `i128` nanoseconds cover any year of the proleptic Gregorian calendar from 0 to 9999:
//! metadata epochs such as StationXML's far-future `endDate="2599-12-31T23:59:59"` do not fit
//! in `i64` nanoseconds (which end in 2262). Leap seconds are not counted (POSIX time, as in
//! MiniSEED and StationXML).

/// Nanoseconds per second.
const NS_PER_S: i128 = 1_000_000_000;

/// Formats ns since the epoch as ISO 8601 UTC (`YYYY-MM-DDThh:mm:ss.fffffffffZ`).
#[must_use]
pub fn format_utc_ns(t_ns: i128) -> String {
    let secs = t_ns.div_euclid(NS_PER_S);
    let ns = t_ns.rem_euclid(NS_PER_S);
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i128::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{ns:09}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// Days from 1970-01-01 to the civil date (Howard Hinnant's `days_from_civil`).
fn days_from_civil(year: i128, month: i128, day: i128) -> i128 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (month + 9) % 12;
    let doy = (153 * mp + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Parses an ISO 8601 date or date-time as written by FDSN web services and ObsPy:
/// `YYYY-MM-DD`, optionally followed by `Thh:mm[:ss[.fraction]]` and a zone `Z`, `+hh:mm` or
/// `-hh:mm` (no zone = UTC). Fractions beyond nanoseconds are truncated. `None` for anything
/// else (out-of-range fields included).
#[must_use]
pub fn parse_utc_ns(text: &str) -> Option<i128> {
    let text = text.trim();
    let (date, time) = match text.split_once(['T', 't', ' ']) {
        Some((d, t)) => (d, Some(t)),
        None => (text, None),
    };
    let mut parts = date.split('-');
    let year: i128 = digits(parts.next()?, 4)?;
    let month: i128 = digits(parts.next()?, 2)?;
    let day: i128 = digits(parts.next()?, 2)?;
    if parts.next().is_some()
        || !(1..=12).contains(&month)
        || day < 1
        || day > month_days(year, month)
    {
        return None;
    }
    let mut seconds = days_from_civil(year, month, day) * 86_400;
    let mut nanos = 0;
    if let Some(time) = time {
        let (clock, offset_s) = split_zone(time)?;
        let mut fields = clock.splitn(3, ':');
        let hour: i128 = digits(fields.next()?, 2)?;
        let minute: i128 = digits(fields.next()?, 2)?;
        let (second, fraction) = match fields.next() {
            None => (0, ""),
            Some(s) => match s.split_once(['.', ',']) {
                Some((whole, frac)) => (digits(whole, 2)?, frac),
                None => (digits(s, 2)?, ""),
            },
        };
        if hour > 24 || minute > 59 || second > 60 || (hour == 24 && (minute, second) != (0, 0)) {
            return None;
        }
        if !fraction.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        for (i, b) in fraction.bytes().take(9).enumerate() {
            nanos += i128::from(b - b'0') * 10i128.pow(8 - i as u32);
        }
        seconds += hour * 3600 + minute * 60 + second - offset_s;
    }
    Some(seconds * NS_PER_S + nanos)
}

/// Splits a time of day from its zone: (`hh:mm:ss…`, offset east of UTC in seconds).
fn split_zone(time: &str) -> Option<(&str, i128)> {
    if let Some(clock) = time.strip_suffix(['Z', 'z']) {
        return Some((clock, 0));
    }
    match time.rfind(['+', '-']) {
        Some(at) => {
            let (clock, zone) = time.split_at(at);
            let sign = if zone.starts_with('-') { -1 } else { 1 };
            let (h, m) = zone[1..].split_once(':').unwrap_or((&zone[1..], "00"));
            let (h, m): (i128, i128) = (digits(h, 2)?, digits(m, 2)?);
            Some((clock, sign * (h * 3600 + m * 60)))
        }
        None => Some((time, 0)),
    }
}

/// Exactly `width` ASCII digits as a number.
fn digits(text: &str, width: usize) -> Option<i128> {
    if text.len() != width || !text.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    text.parse().ok()
}

fn month_days(year: i128, month: i128) -> i128 {
    match month {
        2 if (year % 4 == 0 && year % 100 != 0) || year % 400 == 0 => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_instants_parse_and_format() {
        // 1996-08-10T18:12:24Z = 839700744 s (`date -u -d … +%s`).
        let t = parse_utc_ns("1996-08-10T18:12:24.000000005Z").unwrap();
        assert_eq!(t, 839_700_744 * NS_PER_S + 5);
        assert_eq!(format_utc_ns(t), "1996-08-10T18:12:24.000000005Z");
        assert_eq!(format_utc_ns(-1), "1969-12-31T23:59:59.999999999Z");
        // No zone is UTC; a date alone is midnight; an offset is subtracted.
        assert_eq!(parse_utc_ns("1996-08-10T18:12:24"), Some(t - 5));
        assert_eq!(
            parse_utc_ns("1996-08-10"),
            Some(t - 5 - (18 * 3600 + 12 * 60 + 24) * NS_PER_S)
        );
        assert_eq!(parse_utc_ns("1996-08-10T20:12:24+02:00"), Some(t - 5));
        assert_eq!(
            parse_utc_ns("1996-08-10T18:12"),
            Some(t - 5 - 24 * NS_PER_S)
        );
    }

    #[test]
    fn far_future_epochs_beyond_i64_nanoseconds_round_trip() {
        // 2599-12-31T23:59:59.999 (StationXML's "open" end) is past i64 ns (2262).
        let t = parse_utc_ns("2599-12-31T23:59:59.999").unwrap();
        assert!(t > i128::from(i64::MAX));
        assert_eq!(format_utc_ns(t), "2599-12-31T23:59:59.999000000Z");
        let leap_day = parse_utc_ns("2000-02-29").unwrap();
        assert_eq!(format_utc_ns(leap_day), "2000-02-29T00:00:00.000000000Z");
    }

    #[test]
    fn malformed_times_are_none() {
        for bad in [
            "",
            "2019",
            "2019-13-01",
            "2019-02-29",
            "2019-01-01T25:00:00",
            "2019-1-01",
            "2019-01-01T00:00:00.x",
            "yesterday",
            "2019-01-01T00:00:00+0x:00",
        ] {
            assert_eq!(parse_utc_ns(bad), None, "{bad:?}");
        }
    }
}
