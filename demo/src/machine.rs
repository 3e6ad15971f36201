//! The machine a run measured on, for the report: CPU model, cores, OS, compiler, build
//! profile, load and time. Everything is read from cheap sources (`/proc`, `/etc/os-release`,
//! one `rustc --version`); anything unavailable is `null` in the report, never an error.

use std::fmt::Write as _;
use std::time::{SystemTime, UNIX_EPOCH};

use serde::Serialize;

/// Where and when a run measured.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct Machine {
    /// CPU model name (`/proc/cpuinfo`), or null when not found.
    pub(crate) cpu_model: Option<String>,
    /// Logical cores available to this process.
    pub(crate) logical_cores: usize,
    /// Operating system family (`linux`, `macos`, `windows`, ...).
    pub(crate) os: &'static str,
    /// Distribution name (`/etc/os-release`), or null.
    pub(crate) os_release: Option<String>,
    /// Kernel version (`/proc/sys/kernel/osrelease`), or null.
    pub(crate) kernel: Option<String>,
    /// CPU architecture.
    pub(crate) arch: &'static str,
    /// `rustc --version` of the compiler on PATH (normally the one that built the demo), or null.
    pub(crate) rustc: Option<String>,
    /// `release` (optimised, no debug assertions) or `debug`: timings only mean something in
    /// `release`.
    pub(crate) build: &'static str,
    /// 1-minute load average when the run started (`/proc/loadavg`), or null: a busy machine
    /// makes every timing slower.
    pub(crate) load_average_1min: Option<f64>,
    /// Start of the run, UTC, ISO 8601 (`YYYY-MM-DDThh:mm:ssZ`), or null when the clock is
    /// before 1970.
    pub(crate) started_utc: Option<String>,
    /// Start of the run, seconds since the Unix epoch.
    pub(crate) started_unix_s: u64,
}

impl Machine {
    /// Reads everything now.
    pub(crate) fn detect() -> Machine {
        let now = SystemTime::now();
        Machine {
            cpu_model: cpu_model(),
            logical_cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            os: std::env::consts::OS,
            os_release: os_release(),
            kernel: read_trimmed("/proc/sys/kernel/osrelease"),
            arch: std::env::consts::ARCH,
            rustc: rustc_version(),
            build: if cfg!(debug_assertions) {
                "debug"
            } else {
                "release"
            },
            load_average_1min: read_trimmed("/proc/loadavg")
                .and_then(|s| s.split_whitespace().next()?.parse().ok()),
            started_utc: utc_timestamp(now),
            started_unix_s: now.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()),
        }
    }

    /// One line for the top of the output.
    pub(crate) fn summary(&self) -> String {
        format!(
            "{} ({} logical cores), {}{}, {} build{}",
            self.cpu_model.as_deref().unwrap_or("unknown CPU"),
            self.logical_cores,
            self.os_release.as_deref().unwrap_or(self.os),
            self.rustc
                .as_deref()
                .map(|r| format!(", {r}"))
                .unwrap_or_default(),
            self.build,
            self.load_average_1min
                .map(|l| format!(", load {l:.2}"))
                .unwrap_or_default(),
        )
    }
}

fn read_trimmed(path: &str) -> Option<String> {
    let s = std::fs::read_to_string(path).ok()?;
    let s = s.trim();
    (!s.is_empty()).then(|| s.to_string())
}

pub(crate) fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    // x86 says "model name"; some ARM kernels say "Hardware", "cpu model" or "Processor".
    ["model name", "cpu model", "Hardware", "Processor"]
        .iter()
        .find_map(|key| {
            info.lines().find_map(|l| {
                let (k, v) = l.split_once(':')?;
                (k.trim() == *key && !v.trim().is_empty()).then(|| v.trim().to_string())
            })
        })
}

fn os_release() -> Option<String> {
    let s = std::fs::read_to_string("/etc/os-release").ok()?;
    s.lines().find_map(|l| {
        let v = l.strip_prefix("PRETTY_NAME=")?;
        Some(v.trim_matches('"').to_string())
    })
}

fn rustc_version() -> Option<String> {
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let out = std::process::Command::new(rustc)
        .arg("--version")
        .stdin(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    let s = String::from_utf8(out.stdout).ok()?;
    let s = s.trim();
    (out.status.success() && !s.is_empty()).then(|| s.to_string())
}

/// `time` as `YYYY-MM-DDThh:mm:ssZ` (RFC 3339 / ISO 8601, UTC, whole seconds), or `None` for a
/// time `humantime` cannot format: before 1970 (a clock set wrong) or after 9999.
fn utc_timestamp(time: SystemTime) -> Option<String> {
    // `humantime`'s Display panics before the epoch and fails after 9999: check the first,
    // catch the second through `write!`.
    time.duration_since(UNIX_EPOCH).ok()?;
    let mut text = String::new();
    write!(text, "{}", humantime::format_rfc3339_seconds(time)).ok()?;
    Some(text)
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn iso8601_known_dates() {
        let at = |s: u64| utc_timestamp(UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0).as_deref(), Some("1970-01-01T00:00:00Z"));
        assert_eq!(at(951_782_400).as_deref(), Some("2000-02-29T00:00:00Z"));
        assert_eq!(at(1_700_000_000).as_deref(), Some("2023-11-14T22:13:20Z"));
        assert_eq!(at(4_107_542_399).as_deref(), Some("2100-02-28T23:59:59Z"));
    }

    #[test]
    fn times_humantime_cannot_format_are_none() {
        assert_eq!(utc_timestamp(UNIX_EPOCH - Duration::from_secs(1)), None);
        let year_10000 = UNIX_EPOCH + Duration::from_secs(253_402_300_800);
        assert_eq!(utc_timestamp(year_10000), None);
    }
}
