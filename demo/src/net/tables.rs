//! The net section's tables: Table 2 (step times beside the paper's and Bullet's) and the
//! surface errors of every run, as data and as text.

use slod_experiments::net::{NetReport, NetRun, NetRunKind};
use slod_experiments::table::{Table, num, opt, pct};

use super::records::{NetSection, Table2, Table2Row};
use super::{BulletLike, Figure5};
use crate::paper::{self, TABLE2_BULLET};
use crate::peer;

pub(super) fn table2(
    report: &NetReport,
    fig5: &Figure5,
    bullet_like: BulletLike,
    size: u32,
) -> Table2 {
    let paper_full = paper::TABLE2_TCSB[0].ms_per_step;
    let cpu = crate::machine::cpu_model();
    let peer_bullet = peer::bullet(&peer::results_path(), peer::BULLET_SIZE, cpu.as_deref());
    let paper_row = |p: &paper::PaperStep, group: u32| Table2Row {
        method: p.method.into(),
        compression: p.compression.into(),
        source: "paper",
        nodes: Some(p.nodes as f64),
        links: Some(p.links as f64),
        interpolations: Some(p.interpolations),
        ms_per_step: p.ms_per_step,
        relative_to_no_compression: Some(p.ms_per_step / paper_full),
        group,
    };
    // Our base: the feedback run without compression if there is one (the paper's base), else
    // the reference.
    let ours_full = report
        .run(NetRunKind::Feedback { compression: 1.0 })
        .or_else(|| report.run(NetRunKind::Reference))
        .map_or(f64::NAN, |r| r.ms_per_step);
    let ours_row = |r: &NetRun, method: &str, compression: String, group: u32| Table2Row {
        method: method.into(),
        compression,
        source: "ours",
        nodes: Some(r.nodes),
        links: Some(r.links),
        interpolations: Some(r.interpolations),
        ms_per_step: r.ms_per_step,
        relative_to_no_compression: Some(r.ms_per_step / ours_full),
        group,
    };

    // Group 0: the plain bodies.
    let mut rows = vec![
        paper_row(&TABLE2_BULLET, 0),
        Table2Row {
            method: format!("Bullet btSoftBody {0}x{0}, 20 it", peer_bullet.size),
            compression: "-".into(),
            source: "peer",
            nodes: Some((peer_bullet.size * peer_bullet.size) as f64),
            links: None,
            interpolations: Some(0.0),
            ms_per_step: peer_bullet.ms_per_step.unwrap_or(f64::NAN),
            relative_to_no_compression: None,
            group: 0,
        },
        Table2Row {
            method: format!("Bullet-like cloth {0}x{0}, 20 it", bullet_like.size),
            compression: "-".into(),
            source: "ours",
            nodes: Some(bullet_like.nodes as f64),
            links: Some(bullet_like.links as f64),
            interpolations: Some(0.0),
            ms_per_step: bullet_like.ms_per_step,
            relative_to_no_compression: None,
            group: 0,
        },
    ];
    if let Some(p) = fig5.plain(size) {
        rows.push(Table2Row {
            method: "plain SoftBody, net solver".into(),
            compression: "-".into(),
            source: "ours",
            nodes: Some(p.nodes),
            links: Some(p.links),
            interpolations: Some(0.0),
            ms_per_step: p.ms_per_step,
            relative_to_no_compression: Some(p.ms_per_step / ours_full),
            group: 0,
        });
    }
    // Group 1: no compression (the paper's row, our reference, our feedback at 100%).
    rows.push(paper_row(&paper::TABLE2_TCSB[0], 1));
    if let Some(r) = report.run(NetRunKind::Reference) {
        rows.push(ours_row(r, "TC-SB, no feedback", "reference".into(), 1));
    }
    // Then one group per compression and the time budget.
    let mut group = 1;
    for r in &report.runs {
        match r.kind {
            NetRunKind::Feedback { compression } => {
                let label = format!("{:.0}%", compression * 100.0);
                if compression >= 1.0 {
                    rows.push(ours_row(r, "TC-SB", label, 1));
                    continue;
                }
                group += 1;
                if let Some(p) = paper::table2_row(compression) {
                    rows.push(paper_row(p, group));
                }
                rows.push(ours_row(r, "TC-SB", label, group));
            }
            NetRunKind::TimeBudget { target_ms } => {
                group += 1;
                rows.push(ours_row(
                    r,
                    "TC-SB",
                    format!("{target_ms:.2} ms target"),
                    group,
                ));
            }
            _ => {}
        }
    }
    Table2 {
        rows,
        bullet_like,
        peer_bullet,
        paper_machine: paper::PAPER_MACHINE,
    }
}

pub(super) fn render_table2(s: &NetSection) -> String {
    let c = &s.config;
    let mut t = Table::new(
        format!(
            "Table 2: mean time per step, {0}x{0} net ({1} nodes), {2} steps",
            c.size, c.full_nodes, c.steps
        ),
        &[
            "method",
            "compression",
            "source",
            "N",
            "L",
            "I",
            "ms/step",
            "vs none",
        ],
    );
    let mut previous = None;
    for r in &s.table2.rows {
        if previous.is_some_and(|g| g != r.group) {
            t.rule();
        }
        previous = Some(r.group);
        let source = match r.source {
            "peer" if !r.ms_per_step.is_finite() => "peer, not measured",
            "peer" => "peer, this host",
            other => other,
        };
        t.row([
            r.method.clone(),
            r.compression.clone(),
            source.to_string(),
            opt(r.nodes, 0),
            opt(r.links, 0),
            opt(r.interpolations, 1),
            num(r.ms_per_step, 3),
            opt(r.relative_to_no_compression, 2),
        ]);
    }
    t.note(format!(
        "paper: {}; ours: this machine. `vs none`: time over the same source's TC-SB time \
         without compression.",
        s.table2.paper_machine
    ));
    t.note(
        "Compression is the fraction of nodes simulated. The paper's \"30%\" row simulates 1911 \
         of 4266 nodes (45%): compare N, not labels.",
    );
    let peer = &s.table2.peer_bullet;
    let ours = s.table2.bullet_like.ms_per_step;
    t.note(match peer.ms_per_step {
        Some(ms) => format!(
            "Bullet: {} ms per step ({}); ours at the same settings: {} ms ({}x faster).",
            num(ms, 2),
            peer.source,
            num(ours, 3),
            num(ms / ours, 1)
        ),
        None => format!(
            "Bullet: {}. Ours at Bullet's settings: {} ms per step.",
            peer.source,
            num(ours, 3)
        ),
    });
    t.render()
}

pub(super) fn render_errors(s: &NetSection) -> String {
    let c = &s.config;
    let mut t = Table::new(
        format!(
            "Surface error against the full-resolution reference ({0}x{0}, {1} steps; \
             rest diagonal {2:.2} m)",
            c.size, c.steps, c.diagonal_m
        ),
        &[
            "run",
            "N",
            "ms/step",
            "+recon",
            "speed-up",
            "rms px",
            "p99 px",
            "max px",
            "pop px",
            "rms error",
            "max error",
            "rms mm",
            "max mm",
            "ops",
            "undone",
        ],
    );
    let px = |v: Option<f64>| v.map_or_else(|| "-".into(), |x| num(x, 2));
    for r in s.runs.iter().filter(|r| r.kind != "reference") {
        t.row([
            r.label.clone(),
            num(r.nodes, 0),
            num(r.ms_per_step, 3),
            num(r.reconstruct_ms, 3),
            format!("{}x", num(r.frame_speedup_vs_reference, 2)),
            px(r.screen_rms_px),
            px(r.screen_p99_px),
            px(r.screen_max_px),
            px(r.pop_max_px),
            pct(r.rms_error_fraction as f64, 2),
            pct(r.max_error_fraction as f64, 2),
            num(r.rms_error_mm as f64, 1),
            num(r.max_error_mm as f64, 1),
            r.operations.to_string(),
            r.undone_operations.to_string(),
        ]);
    }
    t.note(format!(
        "On screen (px): the reconstructed finest vertices and the reference's at the same step \
         projected through the net's camera on a {}-pixel-high view ({:.0}° vertical field of \
         view); rms = mean per-frame RMS over the reference's in-view vertices, p99 and max over \
         all vertex-frames, pop = largest frame-to-frame jump of one vertex's error vector.",
        c.measure_height_px, c.fov_y_deg
    ));
    t.note(
        "+recon: reconstruction per step, which a renderer pays on top of the step; speed-up is \
         the reference's step over step + reconstruction. World-space columns: distances in % \
         of the rest diagonal and in mm.",
    );
    t.note(
        "uniform/random: static cuts with the same node count as the strongest compression; the \
         feedback cut should beat both.",
    );
    t.render()
}
