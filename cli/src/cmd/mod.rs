//! One module per subcommand.

pub mod bag;
pub mod bench;
pub mod explain;
pub mod bench_chain;
pub mod composed;
pub mod friction;
pub mod launch;
pub mod param;
pub mod params;
pub mod plot;
pub mod record;
pub mod security;
pub mod sim;
pub mod sim_heldout;
pub mod sim_table;
pub mod tool;

/// A command failure: a message for the user and the exit code.
#[derive(Debug)]
pub struct CliError {
    pub message: String,
    /// 2: the user gave bad input; 1: the command failed; other codes: see the command
    /// (e.g. `naic launch`'s supervision outcome).
    pub code: i32,
}

impl CliError {
    pub fn usage(msg: impl Into<String>) -> Self {
        Self { message: msg.into(), code: 2 }
    }
    pub fn failure(msg: impl Into<String>) -> Self {
        Self { message: msg.into(), code: 1 }
    }
    pub fn with_code(code: i32, msg: impl Into<String>) -> Self {
        Self { message: msg.into(), code }
    }
    pub fn exit_code(&self) -> i32 {
        self.code
    }
}

impl std::fmt::Display for CliError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

pub type CliResult = Result<(), CliError>;

/// UTC calendar time of `secs` seconds since the Unix epoch:
/// `(year, month 1..=12, day 1..=31, hour, minute, second)` (Howard Hinnant's
/// civil-from-days algorithm; no time-zone database needed).
pub fn utc_civil(secs: i64) -> (i64, i64, i64, i64, i64, i64) {
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d, rem / 3600, rem % 3600 / 60, rem % 60)
}

#[cfg(test)]
mod tests {
    #[test]
    fn utc_civil_known_dates() {
        assert_eq!(super::utc_civil(0), (1970, 1, 1, 0, 0, 0));
        assert_eq!(super::utc_civil(1_700_000_000), (2023, 11, 14, 22, 13, 20));
        assert_eq!(super::utc_civil(951_782_400), (2000, 2, 29, 0, 0, 0));
    }
}
