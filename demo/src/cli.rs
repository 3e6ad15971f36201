//! The command line, parsed by hand: `slod-demo [net|crowd] [options]`. Every bad input gives a
//! message naming the option and what it expects; the caller prints it with the usage and
//! exits with [`EXIT_USAGE`]. Nothing here panics, whatever the arguments.

use std::path::PathBuf;

use crate::error::DemoError;

/// Exit status of a bad command line (the convention of `sysexits`-style tools and clap).
pub const EXIT_USAGE: i32 = 2;

/// Exit status of a run that failed after its command line was accepted.
pub const EXIT_FAILURE: i32 = 1;

/// Largest net side accepted: 257² = 66,049 vertices (a 4-level-deeper net than the paper's).
const MAX_SIZE: u32 = 257;

/// The reference run keeps every frame of the finest vertices (12 bytes each) to measure the
/// other runs against it; past this many bytes we refuse rather than let the machine swap.
const MAX_REFERENCE_BYTES: u64 = 3 << 30;

/// The usage text printed by `--help` and after every command-line error.
pub fn usage() -> &'static str {
    "\
slod-demo: simulation and animation level of detail, measured beside the papers

USAGE:
    slod-demo [OPTIONS]              everything: the swinging net, then the crowd (about a minute)
    slod-demo net [OPTIONS]          the swinging net only (simulation paper, section 6)
    slod-demo crowd [OPTIONS]        the crowd only (bone-priority thesis, chapter 13)

OPTIONS:
    --out DIR             where report.json, pictures and plots go [default: out]
    --quick               small sizes, a few seconds (smoke tests); explicit options still apply
    -h, --help            print this text

NET OPTIONS (net, or everything):
    --size N              vertices per side of the square net, 3..=257 [default: 65, the paper's]
    --steps N             simulation steps per run [default: 600]
    --compression LIST    fractions of the full node count run with the feedback loop,
                          comma-separated, each in (0, 1], `%` allowed [default: 1,0.75,0.3]
    --target-ms MS        the time-budget run holds MS milliseconds per step
                          [default: half the measured full-resolution step time]

CROWD OPTIONS (crowd, or everything):
    --gltf PATH           a .glb/.gltf rig with a skin and an animation
                          [default: assets/gltf/GDQuest_GDBot.glb]
    --clip NAME           the animation to play [default: the first named like `walk`, else the first]
    --characters N        number of characters [default: 100]
    --range MIN,MAX       LOD distance range in scene units (characters are 180 units tall)
                          [default: 200,1700, the thesis']
    --budget N            instead of a range: bone interpolations per frame over the whole crowd

EXAMPLES:
    cargo run --release -p slod-demo
    cargo run --release -p slod-demo -- net --size 129 --compression 50%,25%
    cargo run --release -p slod-demo -- crowd --characters 400 --budget 20000 --out runs/budget
"
}

/// Which experiments run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Section {
    /// The net, then the crowd.
    All,
    /// The swinging net only.
    Net,
    /// The crowd only.
    Crowd,
}

impl Section {
    /// The name used on the command line and in the report.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Section::All => "all",
            Section::Net => "net",
            Section::Crowd => "crowd",
        }
    }

    /// Whether the net runs.
    pub(crate) fn net(self) -> bool {
        matches!(self, Section::All | Section::Net)
    }

    /// Whether the crowd runs.
    pub(crate) fn crowd(self) -> bool {
        matches!(self, Section::All | Section::Crowd)
    }
}

/// The user's choices for the net; `None` means the default of the mode (full or quick).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct NetOptions {
    /// Vertices per side.
    pub(crate) size: Option<u32>,
    /// Steps per run.
    pub(crate) steps: Option<u32>,
    /// Compressions run with feedback.
    pub(crate) compressions: Option<Vec<f32>>,
    /// Target of the time-budget run, in milliseconds per step.
    pub(crate) target_ms: Option<f32>,
}

/// How the LOD crowd chooses detail.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum CrowdLod {
    /// The thesis' distance range.
    Range {
        /// Full detail nearer than this.
        min: f32,
        /// Nothing interpolates farther than this.
        max: f32,
    },
    /// A crowd-wide budget of bone interpolations per frame.
    Budget(u32),
}

/// The user's choices for the crowd; `None` means the default.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct CrowdOptions {
    /// The rig file.
    pub(crate) gltf: Option<PathBuf>,
    /// The clip's name.
    pub(crate) clip: Option<String>,
    /// Number of characters.
    pub(crate) characters: Option<usize>,
    /// Range or budget.
    pub(crate) lod: Option<CrowdLod>,
}

/// A parsed command line.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Options {
    /// What runs.
    pub(crate) section: Section,
    /// Output directory.
    pub(crate) out: PathBuf,
    /// Small sizes.
    pub(crate) quick: bool,
    /// Net choices.
    pub(crate) net: NetOptions,
    /// Crowd choices.
    pub(crate) crowd: CrowdOptions,
}

/// What the command line asks for.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Parsed {
    /// Run the experiments.
    Run(Options),
    /// Print the usage and stop.
    Help,
}

fn usage_error(message: String) -> DemoError {
    DemoError::Usage(message)
}

/// Parses the arguments (without the program name).
pub(crate) fn parse(args: &[String]) -> Result<Parsed, DemoError> {
    let mut section: Option<Section> = None;
    let mut out: Option<PathBuf> = None;
    let mut quick = false;
    let mut net = NetOptions::default();
    let mut crowd = CrowdOptions::default();
    // Which section each given option belongs to, to refuse e.g. `crowd --size 9`.
    let mut net_option: Option<&str> = None;
    let mut crowd_option: Option<&str> = None;

    let mut i = 0;
    while i < args.len() {
        let arg = args[i].as_str();
        i += 1;
        if arg == "-h" || arg == "--help" || arg == "help" {
            return Ok(Parsed::Help);
        }
        if !arg.starts_with('-') {
            let s = match arg {
                "net" => Section::Net,
                "crowd" => Section::Crowd,
                "all" => Section::All,
                _ => {
                    return Err(usage_error(format!(
                        "unknown command `{arg}` (expected `net`, `crowd` or none)"
                    )));
                }
            };
            if let Some(previous) = section {
                return Err(usage_error(format!(
                    "two commands given (`{}` and `{arg}`): run one at a time",
                    previous.name()
                )));
            }
            section = Some(s);
            continue;
        }
        // `--name=value` or `--name value`.
        let (name, inline) = match arg.split_once('=') {
            Some((n, v)) => (n, Some(v.to_string())),
            None => (arg, None),
        };
        let mut value = |what: &str| -> Result<String, DemoError> {
            if let Some(v) = inline.clone() {
                return Ok(v);
            }
            match args.get(i) {
                Some(v) if !v.starts_with("--") => {
                    i += 1;
                    Ok(v.clone())
                }
                _ => Err(usage_error(format!("`{name}` needs a value ({what})"))),
            }
        };
        match name {
            "--out" => out = Some(PathBuf::from(non_empty(name, value("a directory")?)?)),
            "--quick" => {
                if inline.is_some() {
                    return Err(usage_error("`--quick` takes no value".into()));
                }
                quick = true;
            }
            "--size" => {
                let v = parse_int(
                    name,
                    &value("vertices per side, e.g. 65")?,
                    3,
                    MAX_SIZE as u64,
                )?;
                net.size = Some(v as u32);
                net_option = Some("--size");
            }
            "--steps" => {
                let v = parse_int(name, &value("steps per run, e.g. 600")?, 1, 1_000_000)?;
                net.steps = Some(v as u32);
                net_option = Some("--steps");
            }
            "--compression" => {
                net.compressions = Some(parse_compressions(&value("e.g. 1,0.75,0.3")?)?);
                net_option = Some("--compression");
            }
            "--target-ms" => {
                let v = parse_float(name, &value("milliseconds per step, e.g. 0.5")?)?;
                if v <= 0.0 {
                    return Err(usage_error(format!(
                        "`--target-ms` must be positive, got {v}"
                    )));
                }
                net.target_ms = Some(v);
                net_option = Some("--target-ms");
            }
            "--gltf" => {
                let path = PathBuf::from(non_empty(name, value("a .glb or .gltf file")?)?);
                if !path.is_file() {
                    return Err(usage_error(format!(
                        "`--gltf`: no such file: {}",
                        path.display()
                    )));
                }
                crowd.gltf = Some(path);
                crowd_option = Some("--gltf");
            }
            "--clip" => {
                crowd.clip = Some(non_empty(name, value("an animation name, e.g. walk")?)?);
                crowd_option = Some("--clip");
            }
            "--characters" => {
                let v = parse_int(name, &value("number of characters, e.g. 100")?, 1, 100_000)?;
                crowd.characters = Some(v as usize);
                crowd_option = Some("--characters");
            }
            "--range" => {
                if matches!(crowd.lod, Some(CrowdLod::Budget(_))) {
                    return Err(usage_error(
                        "`--range` and `--budget` exclude each other: choose one".into(),
                    ));
                }
                crowd.lod = Some(parse_range(&value("MIN,MAX, e.g. 200,1700")?)?);
                crowd_option = Some("--range");
            }
            "--budget" => {
                if matches!(crowd.lod, Some(CrowdLod::Range { .. })) {
                    return Err(usage_error(
                        "`--range` and `--budget` exclude each other: choose one".into(),
                    ));
                }
                let v = parse_int(
                    name,
                    &value("bone interpolations per frame, e.g. 5000")?,
                    1,
                    u32::MAX as u64,
                )?;
                crowd.lod = Some(CrowdLod::Budget(v as u32));
                crowd_option = Some("--budget");
            }
            _ => return Err(usage_error(format!("unknown option `{name}`"))),
        }
    }

    let section = section.unwrap_or(Section::All);
    if let (Section::Crowd, Some(o)) = (section, net_option) {
        return Err(usage_error(format!(
            "`{o}` is a net option; the `crowd` command does not run the net"
        )));
    }
    if let (Section::Net, Some(o)) = (section, crowd_option) {
        return Err(usage_error(format!(
            "`{o}` is a crowd option; the `net` command does not run the crowd"
        )));
    }
    let size = net.size.unwrap_or(65) as u64;
    let steps = net.steps.unwrap_or(600) as u64;
    let bytes = size * size * steps * 12;
    if section.net() && bytes > MAX_REFERENCE_BYTES {
        return Err(usage_error(format!(
            "--size {size} with --steps {steps} needs {} MiB for the reference frames \
             (at most {} MiB): lower one of them",
            bytes >> 20,
            MAX_REFERENCE_BYTES >> 20
        )));
    }
    Ok(Parsed::Run(Options {
        section,
        out: out.unwrap_or_else(|| PathBuf::from("out")),
        quick,
        net,
        crowd,
    }))
}

fn non_empty(name: &str, v: String) -> Result<String, DemoError> {
    if v.trim().is_empty() {
        Err(usage_error(format!("`{name}` needs a non-empty value")))
    } else {
        Ok(v)
    }
}

fn parse_int(name: &str, v: &str, min: u64, max: u64) -> Result<u64, DemoError> {
    let n: u64 = v
        .trim()
        .parse()
        .map_err(|_| usage_error(format!("`{name}` expects a whole number, got `{v}`")))?;
    if n < min || n > max {
        return Err(usage_error(format!(
            "`{name}` must be in {min}..={max}, got {n}"
        )));
    }
    Ok(n)
}

fn parse_float(name: &str, v: &str) -> Result<f32, DemoError> {
    let x: f32 = v
        .trim()
        .parse()
        .map_err(|_| usage_error(format!("`{name}` expects a number, got `{v}`")))?;
    if !x.is_finite() {
        return Err(usage_error(format!("`{name}` must be finite, got `{v}`")));
    }
    Ok(x)
}

/// `1,0.75,0.3` or `100%,75%,30%`: fractions in (0, 1].
fn parse_compressions(v: &str) -> Result<Vec<f32>, DemoError> {
    let mut list = Vec::new();
    for item in v.split(',') {
        let item = item.trim();
        let (number, scale) = match item.strip_suffix('%') {
            Some(n) => (n, 0.01),
            None => (item, 1.0),
        };
        let c = parse_float("--compression", number)? * scale;
        if !(c > 0.0 && c <= 1.0) {
            return Err(usage_error(format!(
                "`--compression` values must be in (0, 1] (or (0%, 100%]), got `{item}`"
            )));
        }
        list.push(c);
    }
    Ok(list)
}

fn parse_range(v: &str) -> Result<CrowdLod, DemoError> {
    let Some((a, b)) = v.split_once(',') else {
        return Err(usage_error(format!(
            "`--range` expects MIN,MAX (e.g. 200,1700), got `{v}`"
        )));
    };
    let (min, max) = (parse_float("--range", a)?, parse_float("--range", b)?);
    if !(min >= 0.0 && min < max) {
        return Err(usage_error(format!(
            "`--range` needs 0 <= MIN < MAX, got {min},{max}"
        )));
    }
    Ok(CrowdLod::Range { min, max })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    fn run(s: &str) -> Options {
        match parse(&args(s)) {
            Ok(Parsed::Run(o)) => o,
            other => panic!("{s}: {other:?}"),
        }
    }

    fn error(s: &str) -> String {
        match parse(&args(s)) {
            Err(DemoError::Usage(m)) => m,
            other => panic!("{s}: expected a usage error, got {other:?}"),
        }
    }

    #[test]
    fn defaults_and_sections() {
        let o = run("");
        assert_eq!(o.section, Section::All);
        assert_eq!(o.out, PathBuf::from("out"));
        assert!(!o.quick);
        assert_eq!(o.net, NetOptions::default());
        assert_eq!(run("net").section, Section::Net);
        assert_eq!(run("--quick crowd").section, Section::Crowd);
        assert!(run("crowd --quick").quick);
        assert_eq!(parse(&args("net --help")).unwrap(), Parsed::Help);
    }

    #[test]
    fn net_options() {
        let o = run("net --size 33 --steps=120 --compression 100%,0.5,25% --target-ms 0.4 --out x");
        assert_eq!(o.net.size, Some(33));
        assert_eq!(o.net.steps, Some(120));
        assert_eq!(o.net.compressions, Some(vec![1.0, 0.5, 0.25]));
        assert_eq!(o.net.target_ms, Some(0.4));
        assert_eq!(o.out, PathBuf::from("x"));
    }

    #[test]
    fn crowd_options() {
        let o = run("crowd --characters 10 --range 100,900 --clip run");
        assert_eq!(o.crowd.characters, Some(10));
        assert_eq!(
            o.crowd.lod,
            Some(CrowdLod::Range {
                min: 100.0,
                max: 900.0
            })
        );
        assert_eq!(o.crowd.clip.as_deref(), Some("run"));
        assert_eq!(
            run("crowd --budget 500").crowd.lod,
            Some(CrowdLod::Budget(500))
        );
    }

    #[test]
    fn bad_options_say_what_is_wrong() {
        assert!(error("--frobnicate").contains("unknown option `--frobnicate`"));
        assert!(error("net --size").contains("needs a value"));
        assert!(error("net --size two").contains("whole number"));
        assert!(error("net --size 2").contains("3..=257"));
        assert!(error("net --compression 0.5,1.5").contains("(0, 1]"));
        assert!(error("net --compression 0").contains("(0, 1]"));
        assert!(error("net --target-ms -1").contains("positive"));
        assert!(error("net --target-ms NaN").contains("finite"));
        assert!(error("crowd --range 5").contains("MIN,MAX"));
        assert!(error("crowd --range 9,3").contains("MIN < MAX"));
        assert!(error("crowd --range 1,2 --budget 3").contains("exclude"));
        assert!(error("crowd --gltf /no/such/file.glb").contains("no such file"));
        assert!(error("crowd --size 9").contains("net option"));
        assert!(error("net --characters 9").contains("crowd option"));
        assert!(error("net crowd").contains("two commands"));
        assert!(error("bake").contains("unknown command"));
        assert!(error("--quick=yes").contains("no value"));
        assert!(error("net --size 257 --steps 100000").contains("MiB"));
        assert!(error("--out").contains("needs a value"));
    }
}
