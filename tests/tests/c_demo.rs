//! The C demo harness (`examples-c/demo.c`) compiled as C11 with every warning an error, linked
//! against the static library built for this run, run, and its printout checked; then run again,
//! shorter, under valgrind memcheck when valgrind is installed (under CI, `CI=true`, a missing
//! valgrind fails the test instead).

use std::path::PathBuf;
use std::process::Command;
use std::sync::OnceLock;

use slod_tests::native::{
    Lang, assert_memcheck_clean, build_executable, memcheck, repo_root, run, run_ok, scratch_dir,
};

/// The demo, built once per test binary.
fn demo() -> &'static PathBuf {
    static DEMO: OnceLock<PathBuf> = OnceLock::new();
    DEMO.get_or_init(|| {
        let dir = scratch_dir("c-demo");
        build_executable(
            Lang::C,
            "c11",
            &[repo_root().join("examples-c/demo.c")],
            &dir.join("demo"),
        )
    })
}

fn rig() -> String {
    repo_root()
        .join("assets/gltf/GDQuest_GDBot.glb")
        .display()
        .to_string()
}

/// The whitespace-separated value after `key` in `line`.
fn field<T: std::str::FromStr>(line: &str, key: &str) -> T {
    let mut words = line.split_whitespace();
    while let Some(w) = words.next() {
        if w == key
            && let Some(v) = words.next().and_then(|v| v.parse().ok())
        {
            return v;
        }
    }
    panic!("no `{key}` value in {line:?}")
}

#[test]
fn c_demo_runs_the_net_and_the_crowd() {
    let steps = 300;
    let out = run_ok(Command::new(demo()).args([
        "--steps",
        &steps.to_string(),
        "--characters",
        "100",
        "--frames",
        "10",
        "--rig",
        &rig(),
    ]));
    println!("{out}");
    let lines: Vec<&str> = out.lines().collect();

    // The net: a summary every 100 steps, the cut near the 30% budget, links and timings sane.
    let full = 65 * 65;
    let net: Vec<&str> = lines
        .iter()
        .copied()
        .filter(|l| l.starts_with("net step"))
        .collect();
    assert_eq!(net.len(), steps / 100, "one summary per 100 steps");
    for (k, l) in net.iter().enumerate() {
        assert_eq!(field::<usize>(l, "step"), (k + 1) * 100);
        let nodes: usize = field(l, "nodes");
        assert!(
            (full as f64 * 0.25..=full as f64 * 0.33).contains(&(nodes as f64)),
            "30% compression of {full} nodes, got {nodes}: {l}"
        );
        let links: usize = field(l, "links");
        assert!(links > 2 * nodes && links < 8 * nodes, "{l}");
        let ms: f64 = field(l, "ms/step");
        assert!(ms.is_finite() && ms > 0.0, "{l}");
    }
    // While the net falls and swings the feedback moves the cut: transitions are blended in the
    // first window (a mean number in flight per step; it settles to 0 once the net hangs still).
    let interpolations: Vec<f64> = net.iter().map(|l| field(l, "interpolations")).collect();
    assert!(interpolations[0] > 0.0, "{interpolations:?}");
    let done = lines
        .iter()
        .find(|l| l.starts_with("net done"))
        .expect("net done line");
    assert_eq!(field::<usize>(done, "steps"), steps);
    assert_eq!(field::<usize>(done, "vertices"), full);
    assert_eq!(field::<i32>(done, "finite"), 1);
    // Pinned at its corners at y = 0, the net sags under gravity.
    let lowest: f64 = field(done, "lowest");
    assert!(lowest < -0.1 && lowest > -2.0, "{done}");
    let w: f64 = field(done, "mean_weight");
    assert!(w > 0.5 && w <= 1.0, "{done}");
    assert!(field::<u64>(done, "evaluations") >= steps as u64 / 5);

    // The crowd: as the camera moves away, fewer bones interpolate and more hold; every animated
    // bone is accounted for at every distance; beyond the range nothing interpolates.
    let rig_line = lines
        .iter()
        .find(|l| l.starts_with("crowd rig"))
        .expect("rig line");
    let bones: u32 = field(rig_line, "bones");
    assert!(bones >= 63, "GDBot has 63 joints: {rig_line}");
    // Per-frame averages: (distance, interpolated, held, frozen).
    let crowd: Vec<(f64, f64, f64, f64)> = lines
        .iter()
        .filter(|l| l.starts_with("crowd distance"))
        .map(|l| {
            (
                field(l, "distance"),
                field(l, "interpolated"),
                field(l, "held"),
                field(l, "frozen"),
            )
        })
        .collect();
    assert!(crowd.len() >= 4, "{crowd:?}");
    let animated = crowd[0].1 + crowd[0].2;
    assert!(animated > 0.0);
    for w in crowd.windows(2) {
        assert!(w[1].0 > w[0].0, "distances grow: {crowd:?}");
        // Up close part of the crowd is outside the view cone (frozen), so the first steps may
        // gain a little as more of it comes into view; beyond that it only falls.
        assert!(
            w[1].1 <= w[0].1 * 1.05,
            "interpolation does not grow with distance: {crowd:?}"
        );
    }
    for c in &crowd {
        assert!(
            (c.1 + c.2 - animated).abs() < 0.2,
            "every animated bone interpolates or holds: {crowd:?}"
        );
    }
    // The budget mode: its units are never overspent, some bones interpolate, and the bones
    // interpolated are at least the units spent (a whole character counts a sixth).
    let budget_line = lines
        .iter()
        .find(|l| l.starts_with("crowd budget"))
        .expect("budget line");
    let (budget, units, interp, over): (f64, f64, f64, u64) = (
        field(budget_line, "budget"),
        field(budget_line, "units"),
        field(budget_line, "interpolated"),
        field(budget_line, "over"),
    );
    assert_eq!(over, 0, "{budget_line}");
    assert!(
        units > 0.0 && units <= budget && interp >= units,
        "{budget_line}"
    );
    let last = crowd.last().unwrap();
    assert_eq!(
        last.1, 0.0,
        "beyond range_max nothing interpolates: {crowd:?}"
    );
    assert_eq!(
        last.3, 100.0,
        "beyond range_max every character is frozen: {crowd:?}"
    );
    assert!(crowd[0].1 > 2.0 * crowd[crowd.len() - 2].1, "{crowd:?}");
    assert!(
        out.contains(&format!("crowd matrices bones {bones} finite 1")),
        "{out}"
    );
    // The cape worn by the walking character: its body colliders touch it, it stays finite,
    // and it hangs from the torso (about 0.83 m up) without falling to the floor.
    let cape = lines
        .iter()
        .find(|l| l.starts_with("cape steps"))
        .expect("cape line");
    assert_eq!(field::<u32>(cape, "colliders"), 6, "{cape}");
    assert_eq!(field::<i32>(cape, "finite"), 1, "{cape}");
    assert!(field::<f64>(cape, "touching") > 0.0, "{cape}");
    let lowest: f64 = field(cape, "lowest");
    assert!(lowest > 0.0 && lowest < 0.6, "{cape}");
    // The world step under a cost-unit budget: deterministic (one worker thread), so the
    // frame cost of the last 30 frames holds the target within 10%; the cloth forced to full
    // detail reached its finest cut; bad budgets, shares and dt were refused.
    let world = lines
        .iter()
        .find(|l| l.starts_with("world frames"))
        .expect("world line");
    let ratio: f64 = field(world, "cost_ratio");
    assert!((0.9..=1.1).contains(&ratio), "{world}");
    assert_eq!(field::<i32>(world, "forced_full"), 1, "{world}");
    assert_eq!(field::<i32>(world, "refused"), 1, "{world}");
    // The rig's structure and its mesh skinned on the CPU, over the C ABI.
    let skin_line = lines
        .iter()
        .find(|l| l.starts_with("crowd bones ordered"))
        .expect("skinning line");
    assert_eq!(field::<i32>(skin_line, "ordered"), 1, "{skin_line}");
    assert!(field::<usize>(skin_line, "meshes") >= 1, "{skin_line}");
    assert!(field::<usize>(skin_line, "vertices") > 0, "{skin_line}");
    assert_eq!(field::<i32>(skin_line, "skinned_finite"), 1, "{skin_line}");
    assert!(
        field::<f64>(skin_line, "error_max_px").is_finite(),
        "{skin_line}"
    );
    // A 120 Hz host with a 60 Hz cloth: the evaluations run ahead on the frames between steps
    // (one per 5 steps), and the run is the same as with the evaluations inside the steps.
    let high = lines
        .iter()
        .find(|l| l.starts_with("high_refresh"))
        .expect("high-refresh line");
    let frames: usize = field(high, "frames");
    assert_eq!(frames, 2 * 240);
    assert_eq!(
        field::<usize>(high, "evaluations_ahead"),
        frames / 2 / 5,
        "{high}"
    );
    assert_eq!(field::<i32>(high, "identical"), 1, "{high}");
    // A net whose evaluations overlap its steps ends the same on two worker threads as on one.
    let overlap = lines
        .iter()
        .find(|l| l.starts_with("overlap"))
        .expect("overlap line");
    assert_eq!(field::<usize>(overlap, "steps"), 240);
    assert_eq!(field::<i32>(overlap, "identical"), 1, "{overlap}");
    assert!(out.contains("world left cloths 0 rigs 0 crowds 0 characters 0"));
    assert!(out.trim_end().ends_with("demo ok"));
}

#[test]
fn c_demo_is_clean_under_valgrind() {
    let Some(mut valgrind) = memcheck() else {
        return;
    };
    let exe = demo();
    let out = run(valgrind
        .arg(exe)
        .args([
            "--steps",
            "20",
            "--characters",
            "10",
            "--frames",
            "3",
            "--rig",
        ])
        .arg(rig()));
    let stdout = assert_memcheck_clean(&out);
    assert!(stdout.contains("demo ok"));
}
