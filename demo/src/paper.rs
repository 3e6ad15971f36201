//! The published figures we print beside ours, copied from the two source documents,
//! `simulation-lod-treecut-softbody-bswdf.txt` (section 6) and
//! `animation-lod-bone-priority-thesis.txt` (chapter 13). Nothing here is measured by the demo
//! (Bullet on this host: `peer`).

use serde::Serialize;

/// The machine of the simulation paper's measurements (its section 6).
pub(crate) const PAPER_MACHINE: &str = "Intel i5 670 at 3.47 GHz, 8 GB RAM (the paper, 2011)";

/// One row of the paper's Table 1 (cost of one TreeCut operation).
#[derive(Clone, Copy, Debug, Serialize)]
pub(crate) struct PaperOp {
    /// The operation as the paper names it.
    pub(crate) operation: &'static str,
    /// Average node count while it was measured.
    pub(crate) nodes: u32,
    /// Link count while it was measured.
    pub(crate) links: u32,
    /// Time spent on nodes (ms).
    pub(crate) node_ops_ms: f64,
    /// Time spent on links (ms).
    pub(crate) link_ops_ms: f64,
    /// Complete time of one operation (ms).
    pub(crate) complete_ms: f64,
}

/// The paper's Table 1: refine, end-refine, coarse, end-coarse.
pub(crate) const TABLE1: [PaperOp; 4] = [
    PaperOp {
        operation: "refine",
        nodes: 4888,
        links: 10419,
        node_ops_ms: 0.0164,
        link_ops_ms: 0.0016,
        complete_ms: 0.0180,
    },
    PaperOp {
        operation: "end-refine",
        nodes: 4889,
        links: 10794,
        node_ops_ms: 0.0017,
        link_ops_ms: 0.0001,
        complete_ms: 0.0018,
    },
    PaperOp {
        operation: "coarse",
        nodes: 4966,
        links: 10615,
        node_ops_ms: 0.0319,
        link_ops_ms: 0.0007,
        complete_ms: 0.0327,
    },
    PaperOp {
        operation: "end-coarse",
        nodes: 4938,
        links: 10917,
        node_ops_ms: 0.0025,
        link_ops_ms: 0.0000,
        complete_ms: 0.0025,
    },
];

/// One row of the paper's Table 2 (mean step time).
#[derive(Clone, Copy, Debug, Serialize)]
pub(crate) struct PaperStep {
    /// The method as the paper names it.
    pub(crate) method: &'static str,
    /// The compression label the paper prints ("-" for Bullet).
    pub(crate) compression: &'static str,
    /// Our compression this row is compared with (None for Bullet).
    #[serde(skip)]
    pub(crate) matches: Option<f32>,
    /// Node count N.
    pub(crate) nodes: u32,
    /// Link count L.
    pub(crate) links: u32,
    /// Interpolations in flight per step I.
    pub(crate) interpolations: f64,
    /// Mean time per step (ms).
    pub(crate) ms_per_step: f64,
}

/// Bullet's plain soft body in the paper's Table 2.
pub(crate) const TABLE2_BULLET: PaperStep = PaperStep {
    method: "Bullet SoftBody",
    compression: "-",
    matches: None,
    nodes: 4266,
    links: 8413,
    interpolations: 0.0,
    ms_per_step: 11.09,
};

/// The TreeCut-SoftBody rows of the paper's Table 2. Its "30%" row simulates 1911 of 4266
/// nodes (45%): the paper does not follow its own definition of compression there, so the
/// rows are matched by label and the node counts printed beside them.
pub(crate) const TABLE2_TCSB: [PaperStep; 3] = [
    PaperStep {
        method: "TC-SB",
        compression: "NoCompression",
        matches: Some(1.0),
        nodes: 4266,
        links: 8647,
        interpolations: 0.0,
        ms_per_step: 10.08,
    },
    PaperStep {
        method: "TC-SB",
        compression: "75%",
        matches: Some(0.75),
        nodes: 3324,
        links: 6931,
        interpolations: 30.5,
        ms_per_step: 8.40,
    },
    PaperStep {
        method: "TC-SB",
        compression: "30%",
        matches: Some(0.30),
        nodes: 1911,
        links: 4220,
        interpolations: 25.1,
        ms_per_step: 4.80,
    },
];

/// The paper's row matching one of our compressions.
pub(crate) fn table2_row(compression: f32) -> Option<&'static PaperStep> {
    TABLE2_TCSB
        .iter()
        .find(|r| r.matches.is_some_and(|m| (m - compression).abs() < 1e-4))
}

/// The thesis' crowd test (chapter 13).
#[derive(Clone, Copy, Debug, Serialize)]
pub(crate) struct Thesis {
    /// Characters in the test.
    pub(crate) characters: u32,
    /// Bones per character.
    pub(crate) bones: u32,
    /// The LOD range (scene units).
    pub(crate) range: [f32; 2],
    /// Frames per second without LOD, at every distance (rendering included).
    pub(crate) fps_without_lod: f64,
    /// Frames per second with LOD once every character is beyond the range.
    pub(crate) fps_with_lod_far: f64,
}

/// The thesis' figures: 12 fps without LOD; 43.6 fps at the far end of the sweep, in both the
/// grid and the random layout. Its per-distance curves are only in its (lost) plots.
pub(crate) const THESIS: Thesis = Thesis {
    characters: 100,
    bones: 153,
    range: [200.0, 1700.0],
    fps_without_lod: 12.0,
    fps_with_lod_far: 43.6,
};

impl Thesis {
    /// Frame cost with LOD over frame cost without, far away (12 / 43.6 = 0.275).
    pub(crate) fn far_cost_ratio(&self) -> f64 {
        self.fps_without_lod / self.fps_with_lod_far
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table2_matches_our_compressions_by_label() {
        assert_eq!(table2_row(1.0).unwrap().nodes, 4266);
        assert_eq!(table2_row(0.3).unwrap().nodes, 1911);
        assert!(table2_row(0.5).is_none());
        // The paper's "30%" is 45% of the nodes and 47.6% of the time.
        let r = table2_row(0.3).unwrap();
        assert!((r.ms_per_step / TABLE2_TCSB[0].ms_per_step - 0.476).abs() < 1e-3);
        assert!((THESIS.far_cost_ratio() - 0.2752).abs() < 1e-3);
    }
}
