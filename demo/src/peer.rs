//! Bullet's soft body measured on this host: the results file of `bench/peers/bullet_cloth.py`
//! (pybullet from PyPI, the same cloths as softbody's `step` benchmark), read for Table 2.
//! Nothing is hard-coded: without a results file from this CPU, Table 2 says how to get one.

use serde::Serialize;
use std::path::{Path, PathBuf};

/// Side of the cloth Table 2 compares with Bullet (the `bullet65` benchmark's).
pub(crate) const BULLET_SIZE: u32 = 65;

/// The command that writes the results file, run from the repository root.
const COMMAND: &str = "python3 bench/peers/bullet_cloth.py";

/// Bullet's figure for one cloth, or why there is none.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct PeerBullet {
    /// What was measured.
    pub(crate) what: String,
    /// Vertices per side of the cloth.
    pub(crate) size: u32,
    /// Solver iterations per step (pybullet forces 20).
    pub(crate) iterations: u32,
    /// Median time per step on this host (ms); null when not measured here.
    pub(crate) ms_per_step: Option<f64>,
    /// Where the figure comes from, or how to measure it.
    pub(crate) source: String,
    /// The results file looked at.
    pub(crate) results_file: String,
}

/// Where the script writes its results: `SLOD_BULLET_RESULTS` if set, else
/// `bench/peers/results/bullet_cloth.json` in the repository.
pub(crate) fn results_path() -> PathBuf {
    std::env::var_os("SLOD_BULLET_RESULTS").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench/peers/results/bullet_cloth.json"),
        PathBuf::from,
    )
}

/// Bullet's figure for the `size`×`size` cloth from the results file at `path`, if it was
/// measured on a CPU like this one (`cpu_model`); otherwise a row that says how to measure it.
pub(crate) fn bullet(path: &Path, size: u32, cpu_model: Option<&str>) -> PeerBullet {
    let what =
        format!("Bullet btSoftBody (pybullet), {size}x{size} triangle-mesh cloth, corners pinned");
    let missing = |why: String| PeerBullet {
        what: what.clone(),
        size,
        iterations: 20,
        ms_per_step: None,
        source: format!("{why}; run `{COMMAND}` to measure it on this host"),
        results_file: path.display().to_string(),
    };
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(_) => return missing("not measured on this host".into()),
    };
    let json: serde_json::Value = match serde_json::from_str(&text) {
        Ok(v) => v,
        Err(e) => return missing(format!("unreadable results file ({e})")),
    };
    let measured_on = json["cpu_model"].as_str().unwrap_or("unknown CPU");
    if cpu_model.is_some_and(|m| m != measured_on) {
        return missing(format!(
            "the results file is from another CPU ({measured_on})"
        ));
    }
    let cloth = json["cloths"].as_array().and_then(|c| {
        c.iter()
            .find(|c| c["size"].as_u64() == Some(u64::from(size)))
    });
    match cloth.and_then(|c| c["median_ms_per_step"].as_f64()) {
        Some(ms) if ms.is_finite() && ms > 0.0 => PeerBullet {
            what,
            size,
            iterations: 20,
            ms_per_step: Some(ms),
            source: format!(
                "{}, measured on this host by `{COMMAND}`",
                json["engine"].as_str().unwrap_or("pybullet")
            ),
            results_file: path.display().to_string(),
        },
        _ => missing(format!("no {size}x{size} cloth in the results file")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("slod-peer-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    const GOOD: &str = r#"{"schema": "slod-peer-bullet/1", "engine": "pybullet 3.2.7",
        "cpu_model": "Test CPU", "cloths": [{"size": 65, "median_ms_per_step": 9.5}]}"#;

    #[test]
    fn reads_the_figure_measured_on_this_cpu() {
        let p = write("good.json", GOOD);
        let b = bullet(&p, 65, Some("Test CPU"));
        assert_eq!(b.ms_per_step, Some(9.5));
        assert!(b.source.contains("this host"));
    }

    #[test]
    fn says_how_to_measure_when_absent_foreign_or_broken() {
        let p = write("good2.json", GOOD);
        for b in [
            bullet(Path::new("/nonexistent/bullet.json"), 65, Some("Test CPU")),
            bullet(&p, 65, Some("Another CPU")),
            bullet(&p, 129, Some("Test CPU")),
            bullet(&write("bad.json", "{not json"), 65, Some("Test CPU")),
        ] {
            assert_eq!(b.ms_per_step, None);
            assert!(b.source.contains(COMMAND), "{}", b.source);
        }
    }
}
