//! Tests of the adaptive cloth and the swinging-net experiment.

use super::net::{NetConfig, NetReport, run_net};

fn print(report: &NetReport) {
    for r in &report.runs {
        eprintln!(
            "{:16} N {:7.1} L {:8.1} I {:5.2} ms {:6.3} eval {:6.3} rms {:.4} max {:.4} ops {} undo {}",
            r.label,
            r.nodes,
            r.links,
            r.interpolations,
            r.ms_per_step,
            r.ms_per_evaluation,
            r.error.rms,
            r.error.max,
            r.operations,
            r.undone_operations
        );
    }
}

#[test]
fn explore_net() {
    let config = NetConfig::paper().unwrap();
    let report = run_net(&config, &mut |_, _, _| {}).unwrap();
    print(&report);
}
