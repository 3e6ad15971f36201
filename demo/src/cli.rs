//! The command line, `slod-demo [net|crowd|perception] [options]`, parsed by `clap` (derive) into
//! [`Options`]. Every bad input gives a message naming the option and what it expects; the
//! caller prints it with the usage and exits with [`EXIT_USAGE`]. Nothing here panics, whatever
//! the arguments.

use std::error::Error as _;
use std::path::PathBuf;

use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser};

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
    USAGE
}

/// See [`usage`]; also clap's help text for [`Cli`].
const USAGE: &str = "\
slod-demo: simulation and animation level of detail, measured beside the papers

USAGE:
    slod-demo [OPTIONS]              everything: the net, the crowd, the engine scenes,
                                     perception, then the world (about a minute and a half)
    slod-demo net [OPTIONS]          the swinging net only (simulation paper, section 6)
    slod-demo crowd [OPTIONS]        the crowd only (bone-priority thesis, chapter 13)
    slod-demo engine [OPTIONS]       the engine scenes only: colliders, wind, a cape on a walking
                                     character; reference and LOD at 30% of the nodes
    slod-demo perception [OPTIONS]   perception only: every strategy on every scene family,
                                     on-screen error in pixels (about a minute)
    slod-demo world [OPTIONS]        the world budget only: 16 cloths and a 1,000-character
                                     crowd, a flying camera, one budget per frame (about 20 s)

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

WORLD OPTIONS (world, or everything):
    --frames N            frames of the budgeted run [default: 300]
    --target-ms MS        with `world`: the frame budget in milliseconds [default: 4]
                          (in the whole run --target-ms is the net's; the world keeps 4 ms)

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
    cargo run --release -p slod-demo -- perception --quick
    cargo run --release -p slod-demo -- world --frames 600 --target-ms 4
";

/// Which experiments run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Section {
    /// The net, then the crowd.
    All,
    /// The swinging net only.
    Net,
    /// The crowd only.
    Crowd,
    /// The engine scenes only.
    Engine,
    /// The perception scenes only.
    Perception,
    /// The world budget only.
    World,
}

impl Section {
    /// The name used on the command line and in the report.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Section::All => "all",
            Section::Net => "net",
            Section::Crowd => "crowd",
            Section::Engine => "engine",
            Section::Perception => "perception",
            Section::World => "world",
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

    /// Whether the engine scenes run.
    pub(crate) fn engine(self) -> bool {
        matches!(self, Section::All | Section::Engine)
    }

    /// Whether the perception scenes run.
    pub(crate) fn perception(self) -> bool {
        matches!(self, Section::All | Section::Perception)
    }

    /// Whether the world budget runs.
    pub(crate) fn world(self) -> bool {
        matches!(self, Section::All | Section::World)
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

/// The user's choices for the world budget; `None` means the default.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct WorldOptions {
    /// Frames of the budgeted run.
    pub(crate) frames: Option<u32>,
    /// The frame budget, ms (only with the `world` command).
    pub(crate) target_ms: Option<f32>,
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
    /// World choices.
    pub(crate) world: WorldOptions,
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

/// One word without a leading `-`: a command, or `help`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Word {
    /// `net`, `crowd`, `perception` or `all`.
    Run(Section),
    /// `help`, as `--help`.
    Help,
}

/// A `--compression` list (a newtype, so that clap takes it as one value).
#[derive(Clone, Debug)]
struct Compressions(Vec<f32>);

/// The command line as clap sees it. Each option's doc comment is the hint a missing value
/// gets; the value parsers give the other messages. [`parse`] turns it into [`Options`].
#[derive(Debug, Parser)]
#[command(
    name = "slod-demo",
    override_help = USAGE,
    disable_version_flag = true,
    args_override_self = true
)]
struct Cli {
    /// a command
    #[arg(value_name = "COMMAND", value_parser = word)]
    words: Vec<Word>,
    /// a directory
    #[arg(long, value_parser = non_empty("--out"))]
    out: Option<String>,
    /// no value
    #[arg(long)]
    quick: bool,
    /// vertices per side, e.g. 65
    #[arg(
        long,
        allow_negative_numbers = true,
        value_parser = whole::<u32>("--size", 3, MAX_SIZE.into()),
    )]
    size: Option<u32>,
    /// steps per run, e.g. 600
    #[arg(
        long,
        allow_negative_numbers = true,
        value_parser = whole::<u32>("--steps", 1, 1_000_000),
    )]
    steps: Option<u32>,
    /// e.g. 1,0.75,0.3
    #[arg(long, allow_negative_numbers = true, value_parser = compressions)]
    compression: Option<Compressions>,
    /// milliseconds per step, e.g. 0.5
    #[arg(long, allow_negative_numbers = true, value_parser = target_ms)]
    target_ms: Option<f32>,
    /// a .glb or .gltf file
    #[arg(long, value_parser = gltf_file)]
    gltf: Option<PathBuf>,
    /// an animation name, e.g. walk
    #[arg(long, value_parser = non_empty("--clip"))]
    clip: Option<String>,
    /// number of characters, e.g. 100
    #[arg(
        long,
        allow_negative_numbers = true,
        value_parser = whole::<usize>("--characters", 1, 100_000),
    )]
    characters: Option<usize>,
    /// MIN,MAX, e.g. 200,1700
    #[arg(long, allow_negative_numbers = true, value_parser = range, conflicts_with = "budget")]
    range: Option<CrowdLod>,
    /// frames of the world run, e.g. 600
    #[arg(
        long,
        allow_negative_numbers = true,
        value_parser = whole::<u32>("--frames", 1, 100_000),
    )]
    frames: Option<u32>,
    /// bone interpolations per frame, e.g. 5000
    #[arg(
        long,
        allow_negative_numbers = true,
        value_parser = whole::<u32>("--budget", 1, u32::MAX.into()),
    )]
    budget: Option<u32>,
}

/// The net's options (clap id, flag), to refuse them with the `crowd` command.
const NET_OPTIONS: [(&str, &str); 4] = [
    ("size", "--size"),
    ("steps", "--steps"),
    ("compression", "--compression"),
    ("target_ms", "--target-ms"),
];

/// The crowd's options (clap id, flag), to refuse them with the `net` command.
const CROWD_OPTIONS: [(&str, &str); 5] = [
    ("gltf", "--gltf"),
    ("clip", "--clip"),
    ("characters", "--characters"),
    ("range", "--range"),
    ("budget", "--budget"),
];

/// Parses the arguments (without the program name).
pub(crate) fn parse(args: &[String]) -> Result<Parsed, DemoError> {
    let argv = std::iter::once("slod-demo").chain(args.iter().map(String::as_str));
    let matches = match Cli::command().try_get_matches_from(argv) {
        Ok(m) => m,
        Err(e) if e.kind() == ErrorKind::DisplayHelp => return Ok(Parsed::Help),
        Err(e) => return Err(usage_error(message(&e))),
    };
    let cli = Cli::from_arg_matches(&matches).map_err(|e| usage_error(message(&e)))?;

    if cli.words.contains(&Word::Help) {
        return Ok(Parsed::Help);
    }
    let sections: Vec<Section> = cli
        .words
        .iter()
        .filter_map(|w| match w {
            Word::Run(s) => Some(*s),
            Word::Help => None,
        })
        .collect();
    let section = match sections.as_slice() {
        [] => Section::All,
        [s] => *s,
        [first, second, ..] => {
            return Err(usage_error(format!(
                "two commands given (`{}` and `{}`): run one at a time",
                first.name(),
                second.name()
            )));
        }
    };
    if let (Section::Crowd, Some(o)) = (section, last_given(&matches, &NET_OPTIONS)) {
        return Err(usage_error(format!(
            "`{o}` is a net option; the `crowd` command does not run the net"
        )));
    }
    if let (Section::Net | Section::Crowd | Section::Engine | Section::Perception, Some(_)) =
        (section, cli.frames)
    {
        return Err(usage_error(format!(
            "`--frames` is a world option; the `{}` command does not run the world",
            section.name()
        )));
    }
    if section == Section::World
        && let Some(o) =
            last_given(&matches, &NET_OPTIONS[..3]).or_else(|| last_given(&matches, &CROWD_OPTIONS))
    {
        return Err(usage_error(format!(
            "`{o}` is a net or crowd option; the `world` command runs neither"
        )));
    }
    if matches!(section, Section::Engine | Section::Perception)
        && let Some(o) =
            last_given(&matches, &NET_OPTIONS).or_else(|| last_given(&matches, &CROWD_OPTIONS))
    {
        return Err(usage_error(format!(
            "`{o}` is a net or crowd option; the `{}` command runs neither",
            section.name()
        )));
    }
    if let (Section::Net, Some(o)) = (section, last_given(&matches, &CROWD_OPTIONS)) {
        return Err(usage_error(format!(
            "`{o}` is a crowd option; the `net` command does not run the crowd"
        )));
    }
    let size = cli.size.unwrap_or(65) as u64;
    let steps = cli.steps.unwrap_or(600) as u64;
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
        out: PathBuf::from(cli.out.as_deref().unwrap_or("out")),
        quick: cli.quick,
        net: NetOptions {
            size: cli.size,
            steps: cli.steps,
            compressions: cli.compression.map(|c| c.0),
            target_ms: cli.target_ms.filter(|_| section != Section::World),
        },
        crowd: CrowdOptions {
            gltf: cli.gltf,
            clip: cli.clip,
            characters: cli.characters,
            lod: cli.range.or(cli.budget.map(CrowdLod::Budget)),
        },
        world: WorldOptions {
            frames: cli.frames,
            target_ms: cli.target_ms.filter(|_| section == Section::World),
        },
    }))
}

/// The flag of `options` given last on the command line, if any.
fn last_given<'a>(matches: &ArgMatches, options: &[(&str, &'a str)]) -> Option<&'a str> {
    options
        .iter()
        .filter_map(|&(id, flag)| Some((matches.index_of(id)?, flag)))
        .max_by_key(|&(index, _)| index)
        .map(|(_, flag)| flag)
}

/// Our message for a clap error: the value parsers' own text, or one in the same style for
/// what clap itself refuses.
fn message(e: &clap::Error) -> String {
    // "--size <N>" -> "--size".
    let flag = match e.get(ContextKind::InvalidArg) {
        Some(ContextValue::String(s)) => s.split_whitespace().next().unwrap_or(s).to_string(),
        _ => String::new(),
    };
    match e.kind() {
        ErrorKind::ValueValidation => {
            if let Some(source) = e.source() {
                return source.to_string();
            }
        }
        ErrorKind::UnknownArgument => return format!("unknown option `{flag}`"),
        ErrorKind::InvalidValue | ErrorKind::NoEquals => {
            let hint = Cli::command()
                .get_arguments()
                .find(|a| a.get_long().is_some_and(|l| flag == format!("--{l}")))
                .and_then(|a| a.get_help().map(ToString::to_string));
            return match hint {
                Some(hint) => format!("`{flag}` needs a value ({hint})"),
                None => format!("`{flag}` needs a value"),
            };
        }
        ErrorKind::TooManyValues => return format!("`{flag}` takes no value"),
        // The only conflict declared.
        ErrorKind::ArgumentConflict => {
            return "`--range` and `--budget` exclude each other: choose one".into();
        }
        _ => {}
    }
    // Anything else: clap's own first line, without its `error: `.
    let text = e.render().to_string();
    let line = text.lines().next().unwrap_or_default();
    line.strip_prefix("error: ").unwrap_or(line).to_string()
}

fn word(v: &str) -> Result<Word, String> {
    Ok(match v {
        "net" => Word::Run(Section::Net),
        "crowd" => Word::Run(Section::Crowd),
        "engine" => Word::Run(Section::Engine),
        "perception" => Word::Run(Section::Perception),
        "world" => Word::Run(Section::World),
        "all" => Word::Run(Section::All),
        "help" => Word::Help,
        _ => {
            return Err(format!(
                "unknown command `{v}` (expected `net`, `crowd`, `engine`, `perception`, `world` or none)"
            ));
        }
    })
}

fn non_empty(name: &'static str) -> impl Fn(&str) -> Result<String, String> + Clone {
    move |v| {
        if v.trim().is_empty() {
            Err(format!("`{name}` needs a non-empty value"))
        } else {
            Ok(v.to_string())
        }
    }
}

/// A whole number in `min..=max` (which fits `T`).
fn whole<T: TryFrom<u64>>(
    name: &'static str,
    min: u64,
    max: u64,
) -> impl Fn(&str) -> Result<T, String> + Clone {
    move |v| {
        let n: u64 = v
            .trim()
            .parse()
            .map_err(|_| format!("`{name}` expects a whole number, got `{v}`"))?;
        if n < min || n > max {
            return Err(format!("`{name}` must be in {min}..={max}, got {n}"));
        }
        T::try_from(n).map_err(|_| format!("`{name}` must be in {min}..={max}, got {n}"))
    }
}

fn number(name: &str, v: &str) -> Result<f32, String> {
    let x: f32 = v
        .trim()
        .parse()
        .map_err(|_| format!("`{name}` expects a number, got `{v}`"))?;
    if !x.is_finite() {
        return Err(format!("`{name}` must be finite, got `{v}`"));
    }
    Ok(x)
}

fn target_ms(v: &str) -> Result<f32, String> {
    let ms = number("--target-ms", v)?;
    if ms <= 0.0 {
        return Err(format!("`--target-ms` must be positive, got {ms}"));
    }
    Ok(ms)
}

fn gltf_file(v: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(non_empty("--gltf")(v)?);
    if !path.is_file() {
        return Err(format!("`--gltf`: no such file: {}", path.display()));
    }
    Ok(path)
}

/// `1,0.75,0.3` or `100%,75%,30%`: fractions in (0, 1].
fn compressions(v: &str) -> Result<Compressions, String> {
    let mut list = Vec::new();
    for item in v.split(',') {
        let item = item.trim();
        let (number_text, scale) = match item.strip_suffix('%') {
            Some(n) => (n, 0.01),
            None => (item, 1.0),
        };
        let c = number("--compression", number_text)? * scale;
        if !(c > 0.0 && c <= 1.0) {
            return Err(format!(
                "`--compression` values must be in (0, 1] (or (0%, 100%]), got `{item}`"
            ));
        }
        list.push(c);
    }
    Ok(Compressions(list))
}

fn range(v: &str) -> Result<CrowdLod, String> {
    let Some((a, b)) = v.split_once(',') else {
        return Err(format!(
            "`--range` expects MIN,MAX (e.g. 200,1700), got `{v}`"
        ));
    };
    let (min, max) = (number("--range", a)?, number("--range", b)?);
    if !(min >= 0.0 && min < max) {
        return Err(format!("`--range` needs 0 <= MIN < MAX, got {min},{max}"));
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
        assert_eq!(run("perception --quick").section, Section::Perception);
        assert_eq!(run("--quick crowd").section, Section::Crowd);
        assert!(run("crowd --quick").quick);
        assert_eq!(parse(&args("net --help")).unwrap(), Parsed::Help);
        assert_eq!(run("world").section, Section::World);
    }

    #[test]
    fn world_options() {
        let o = run("world --frames 600 --target-ms 3.5");
        assert_eq!(o.world.frames, Some(600));
        assert_eq!(o.world.target_ms, Some(3.5));
        assert_eq!(o.net.target_ms, None);
        // In the whole run --target-ms stays the net's.
        let o = run("--frames 90 --target-ms 0.4");
        assert_eq!((o.world.frames, o.world.target_ms), (Some(90), None));
        assert_eq!(o.net.target_ms, Some(0.4));
        assert!(error("world --size 9").contains("world"));
        assert!(error("world --characters 9").contains("world"));
        assert!(error("net --frames 9").contains("world option"));
        assert!(error("world --frames 0").contains("1..=100000"));
        assert!(error("world --target-ms 0").contains("positive"));
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
    fn clap_command_is_consistent() {
        Cli::command().debug_assert();
        assert_eq!(Cli::command().render_help().to_string(), usage());
        // A repeated option keeps its last value, as the hand parser did.
        assert_eq!(run("net --size 9 --size=17").net.size, Some(17));
        assert_eq!(run("-- crowd").section, Section::Crowd);
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
        assert!(error("perception --size 9").contains("perception"));
        assert!(error("perception --characters 9").contains("perception"));
        assert!(error("bake").contains("unknown command"));
        assert!(error("--quick=yes").contains("no value"));
        assert!(error("net --size 257 --steps 100000").contains("MiB"));
        assert!(error("--out").contains("needs a value"));
    }
}
