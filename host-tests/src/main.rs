//! `cargo run -p host-tests --release -- campaign [--episodes N] [--seconds S] [--out DIR]`
//!
//! Runs every (leader, follower) group with the firmware's default table from certified starts,
//! prints a table of the results, writes `DIR/campaign.json` and a PNG plot of the episode of
//! each group with the smallest certificate margin. Exits non-zero if a group ran no episodes
//! (no certified start could be drawn), or if humans within the model collided with the ego or
//! took the state out of the certified set: either means the certificate is wrong.
//!
//! `cargo run -p host-tests --release -- falsify [--episodes N] [--seed S] [--out DIR]` runs the
//! adversarial search ([`host_tests::falsify`]), prints its figures per method, writes
//! `DIR/findings.json`, and exits non-zero on any collision or certificate loss.
//! `replay FINDINGS (--worst METHOD | --finding K) [--out DIR]` replays one case of a findings
//! file to `DIR/trace.json` and `DIR/trace.png`, with the certificate and table the search
//! recorded in the file unless given others.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use host_tests::campaign::{run_episode, CutInKind, Sensing, Trace};
use host_tests::falsify::AfterReaction;
use host_tests::sim::ActuatorModel;
use host_tests::world::EmergencyCauses;
use host_tests::SensorModel;
use indicatif::{ProgressBar, ProgressStyle};
use table_format::{Game, Table};

#[derive(Parser)]
#[command(about = "Closed-loop campaigns of the hjacc firmware")]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
// A negative number is a value (refused with a reason), not an unknown flag.
#[command(allow_negative_numbers = true)]
enum Command {
    /// Runs the safety campaign.
    Campaign(CampaignArgs),
    /// Runs the adversarial search: certified starts on the boundary and the domain's edges,
    /// humans chosen by search within the model.
    #[command(allow_negative_numbers = true)]
    Falsify {
        /// Episodes over every method, about.
        #[arg(long, default_value_t = 5_000)]
        episodes: usize,
        /// Simulated seconds per episode.
        #[arg(long, default_value_t = 120.0)]
        seconds: f32,
        /// The search's seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output folder.
        #[arg(long, default_value = "out/falsify")]
        out: PathBuf,
        /// A table file to run instead of the firmware's default table.
        #[arg(long, value_name = "FILE")]
        table: Option<PathBuf>,
        #[command(flatten)]
        certificate: CertificateArgs,
        /// Followers that see the ego's brake lights only after their reaction time (the
        /// two-authority certificate's follower, at its worst: the largest acceleration until
        /// then); needs `--authorities two`.
        #[arg(long)]
        follower_reacts: bool,
        /// What those followers do once they have reacted, while the lights stay on:
        /// `at-its-level` brakes as the certificate's follower does (within the model);
        /// `by-its-idm` drives by its IDM (beyond the model: the search reports what it finds
        /// and does not fail on it). Needs `--follower-reacts`.
        #[arg(long, value_enum, default_value_t = AfterReaction::AtItsLevel)]
        after_reaction: AfterReaction,
    },
    /// Runs the scenario suite (openpilot's maneuvers, Euro NCAP's CCR tests, hjacc's own
    /// checks) under ISO 15622's comfort checks, with the graded override and the paper's
    /// bang-bang policy.
    Scenarios {
        /// Output folder.
        #[arg(long, default_value = "out/scenarios")]
        out: PathBuf,
        /// Only scenarios whose name contains this.
        #[arg(long)]
        only: Option<String>,
        #[command(flatten)]
        certificate: CertificateArgs,
    },
    /// Plots the nominal law's gap policy beside the certificate's steady-following gap, at
    /// every time-gap setting, with and without the braking ramp.
    GapPolicy {
        /// Output folder.
        #[arg(long, default_value = "out/gap-policy")]
        out: PathBuf,
    },
    /// Measures what a committed move-off would certify at a standstill with a follower
    /// stopped close behind: the shortest commitment, and the leader's room the front needs.
    MoveOff {
        /// Output folder.
        #[arg(long, default_value = "out/move-off")]
        out: PathBuf,
    },
    /// Replays one case of a findings file and writes its trace.
    Replay {
        /// The findings file (`falsify`'s `findings.json`).
        findings: PathBuf,
        /// The case with the smallest margin of this method (structured, random,
        /// cross_entropy, hill_climbing, greedy).
        #[arg(long, conflicts_with = "finding")]
        worst: Option<String>,
        /// The K-th collision or loss (from 0).
        #[arg(long)]
        finding: Option<usize>,
        /// Output folder.
        #[arg(long, default_value = "out/replay")]
        out: PathBuf,
        /// A table file to run instead of the firmware's default table.
        #[arg(long, value_name = "FILE")]
        table: Option<PathBuf>,
        /// The certificate the findings were searched with.
        #[command(flatten)]
        certificate: CertificateArgs,
    },
}

/// Runs [`real_main`]; a user error (a bad flag, an empty group, a failed campaign) is
/// one clean message on stderr and exit code 1, with or without `RUST_BACKTRACE` (anyhow's
/// `Debug` output would print a backtrace of this function, which tells a user nothing).
fn main() -> std::process::ExitCode {
    match real_main() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// The table's bytes: the file, or the firmware's default table.
fn table_bytes(table: &Option<PathBuf>) -> Result<&'static [u8]> {
    Ok(match table {
        Some(path) => std::fs::read(path)
            .with_context(|| format!("reading {}", path.display()))?
            .leak(),
        None => firmware::DEFAULT_TABLE,
    })
}

/// Which brakings the firmware's certificate argues with ([`firmware::Authorities`]).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
enum AuthoritiesArg {
    /// The comfort band alone, the rear half the table's (the default configuration).
    Band,
    /// Two authorities: the emergency authority's build-up at the level the follower allows.
    Two,
}

impl AuthoritiesArg {
    /// As the command line spells it.
    fn flag(self) -> &'static str {
        match self {
            AuthoritiesArg::Band => "band",
            AuthoritiesArg::Two => "two",
        }
    }
}

/// The certificate's configuration and the leader it is run against.
#[derive(clap::Args, Clone, Debug, PartialEq)]
struct CertificateArgs {
    /// Which brakings the certificate argues with [default: band; `replay`: the search's].
    #[arg(long, value_enum)]
    authorities: Option<AuthoritiesArg>,
    /// The leader's hardest braking, m/s^2 (positive): the table's leader declared anew
    /// (`table_format::with_leader`; the rear table does not depend on it), or `table` for the
    /// table's own. The table's own without it (`replay`: the search's).
    #[arg(long, value_name = "M_PER_S2|table")]
    leader_braking: Option<LeaderBraking>,
}

/// `--leader-braking`: the table's own leader, or one declared anew.
#[derive(Clone, Copy, Debug, PartialEq)]
enum LeaderBraking {
    /// The table's own leader (what a run without the flag uses; for `replay`, what undoes a
    /// search's declaration).
    Table,
    /// The leader's hardest braking declared anew, m/s^2 (positive).
    Declared(f32),
}

impl LeaderBraking {
    /// The braking declared anew, `None` for the table's own.
    fn declared(self) -> Option<f32> {
        match self {
            LeaderBraking::Table => None,
            LeaderBraking::Declared(b) => Some(b),
        }
    }
}

impl std::str::FromStr for LeaderBraking {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        if s == "table" {
            return Ok(LeaderBraking::Table);
        }
        s.parse::<f32>().map(LeaderBraking::Declared).map_err(|_| {
            format!("expected a braking in m/s^2 or `table` for the table's own, got {s:?}")
        })
    }
}

impl CertificateArgs {
    /// The authorities, the comfort band unless given.
    fn authorities(&self) -> AuthoritiesArg {
        self.authorities.unwrap_or(AuthoritiesArg::Band)
    }

    /// The leader's braking declared anew, m/s^2 (`None`: the table's own).
    fn declared_leader(&self) -> Option<f32> {
        self.leader_braking.and_then(LeaderBraking::declared)
    }

    /// These arguments as they are given on the command line (nothing for the defaults), for
    /// a command that must run with the same certificate.
    fn flags(&self) -> String {
        let mut flags = String::new();
        if self.authorities() == AuthoritiesArg::Two {
            flags.push_str(" --authorities two");
        }
        if let Some(b) = self.declared_leader() {
            flags.push_str(&format!(" --leader-braking {b}"));
        }
        flags
    }

    /// The table's bytes with the leader declared, and the configuration.
    fn resolve(&self, bytes: &'static [u8]) -> Result<(&'static [u8], firmware::Config)> {
        let bytes = match self.declared_leader() {
            Some(b) => {
                anyhow::ensure!(
                    b.is_finite() && b > 0.0,
                    "--leader-braking must be a finite braking above 0 m/s^2 (got {b})"
                );
                let table = Table::parse(bytes)
                    .map_err(|e| anyhow::anyhow!("the table does not parse: {e}"))?;
                let Game::ThreeCarSplit { leader, .. } = table.header().game else {
                    anyhow::bail!("--leader-braking needs a split three-car table");
                };
                table_format::with_leader(
                    bytes,
                    table_format::Bounds {
                        min: -b,
                        max: leader.max,
                    },
                )
                .map_err(|e| anyhow::anyhow!("--leader-braking {b}: {e}"))?
                .leak()
            }
            None => bytes,
        };
        let mut config = firmware::Config::default();
        config.certificate.authorities = match self.authorities() {
            AuthoritiesArg::Band => firmware::Authorities::ComfortBand,
            AuthoritiesArg::Two => firmware::Authorities::Two,
        };
        Ok((bytes, config))
    }
}

/// The search's setting on a table: within the model of `config`, with followers that react to
/// the brake lights late where `follower_reacts`, doing `after` once they have reacted.
fn search_setting<'t>(
    bytes: &'t [u8],
    table: &'t Table<'t>,
    model: host_tests::humans::HumanModel,
    config: firmware::Config,
    follower_reacts: bool,
    after: host_tests::falsify::AfterReaction,
) -> Result<host_tests::falsify::Setting<'t>> {
    let setting = host_tests::falsify::Setting::within_model(bytes, table, model, config);
    if !follower_reacts {
        return Ok(setting);
    }
    setting
        .with_reacting_follower(after)
        .ok_or_else(|| anyhow::anyhow!("the firmware does not accept the table"))
}

/// A split table and its model of the humans.
fn split_table(bytes: &'static [u8]) -> Result<(Table<'static>, host_tests::humans::HumanModel)> {
    let table =
        Table::parse(bytes).map_err(|e| anyhow::anyhow!("the table does not parse: {e}"))?;
    let model = host_tests::humans::HumanModel::of(&table).ok_or_else(|| {
        anyhow::anyhow!(
            "the closed loop runs split three-car tables (the firmware's); this one is {:?}",
            table.header().game.kind()
        )
    })?;
    Ok((table, model))
}

/// Refuses a count of zero, naming the argument.
fn positive_count(name: &str, n: usize) -> Result<()> {
    anyhow::ensure!(
        n > 0,
        "--{name} must be at least 1 (got 0): nothing would be tested"
    );
    Ok(())
}

/// Refuses a duration that is not a finite number of seconds above zero, naming the argument.
fn positive_seconds(name: &str, s: f32) -> Result<()> {
    anyhow::ensure!(
        s.is_finite() && s > 0.0,
        "--{name} must be a finite number of seconds above 0 (got {s})"
    );
    Ok(())
}

fn real_main() -> Result<()> {
    solver::output::register_plot_font()?;
    let args: Args = solver::cli::parse_args();
    match args.command {
        Command::Falsify {
            episodes,
            seconds,
            seed,
            out,
            table,
            certificate,
            follower_reacts,
            after_reaction,
        } => {
            anyhow::ensure!(
                follower_reacts || after_reaction == AfterReaction::AtItsLevel,
                "--after-reaction needs --follower-reacts: a follower that sees the ego at once \
                 has no reaction to come after"
            );
            falsify(
                episodes,
                seconds,
                seed,
                &out,
                &table,
                &certificate,
                follower_reacts.then_some(after_reaction),
            )
        }
        Command::Replay {
            findings,
            worst,
            finding,
            out,
            table,
            certificate,
        } => replay(
            &findings,
            worst.as_deref(),
            finding,
            &out,
            &table,
            &certificate,
        ),
        Command::Campaign(args) => campaign(args),
        Command::Scenarios {
            out,
            only,
            certificate,
        } => scenarios(&out, only.as_deref(), &certificate),
        Command::GapPolicy { out } => host_tests::gap_policy::run(&out),
        Command::MoveOff { out } => host_tests::move_off::run(&out),
    }
}

fn falsify(
    episodes: usize,
    seconds: f32,
    seed: u64,
    out: &std::path::Path,
    table: &Option<PathBuf>,
    certificate: &CertificateArgs,
    reacting: Option<host_tests::falsify::AfterReaction>,
) -> Result<()> {
    use host_tests::falsify::{search, Budget};
    let follower_reacts = reacting.is_some();
    let beyond_model = reacting == Some(AfterReaction::ByItsIdm);
    // The replay runs the certificate and table it is given, not the file's: the hint at the
    // end carries the search's own (a finding of two authorities replayed in the band is
    // clean).
    let table_flag = table
        .as_ref()
        .map_or(String::new(), |t| format!(" --table {}", t.display()));
    positive_count("episodes", episodes)?;
    positive_seconds("seconds", seconds)?;
    anyhow::ensure!(
        !follower_reacts || certificate.authorities() == AuthoritiesArg::Two,
        "--follower-reacts needs --authorities two: the comfort band's rear half argues with \
         the table's IDM, which sees the ego at once"
    );
    let searched = Searched {
        authorities: certificate.authorities(),
        leader_braking: certificate.declared_leader(),
        table: table.clone(),
    };
    let (bytes, config) = certificate.resolve(table_bytes(table)?)?;
    let (table, model) = split_table(bytes)?;
    let setting = search_setting(
        bytes,
        &table,
        model,
        config,
        follower_reacts,
        reacting.unwrap_or_default(),
    )?;
    let budget = Budget::scaled(episodes, seconds);
    let bar = ProgressBar::new(budget.episodes() as u64);
    bar.set_style(
        ProgressStyle::with_template("[{bar:40}] {pos}/{len} episodes ({elapsed}, eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let report = search(&setting, &budget, seed, &|n| bar.inc(n as u64));
    bar.finish_and_clear();
    println!(
        "| method | episodes | collisions | of them unavoidable | certificate losses (nominal/override/min-risk/uncertified; front/rear/speed/domain) | uncertified periods | min front [m] | min rear [m] | min speed headroom [m/s] | min gap front [m] | min gap rear [m] | max ego speed engaged [m/s] | accelerating starts at 34-35 m/s | followers at 35 m/s | starts refused at engagement, drawn again (episodes refused) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for m in &report.methods {
        let (b, p) = (m.losses_by_mode, m.losses_by_part);
        println!(
            "| {:?} | {} | {} | {} | {} ({}/{}/{}/{}; {}/{}/{}/{}) | {} | {:.4} | {:.4} | {:.4} | {:.2} | {:.3} | {:.3} | {} | {} | {} ({}) |",
            m.method, m.episodes, m.collisions, m.collisions_unavoidable, m.certificate_losses,
            b[0], b[1], b[2], b[3], p[0], p[1], p[2], p[3], m.uncertified_periods,
            m.min_front_m, m.min_rear_m, m.min_speed_headroom_m_per_s, m.min_gap_leader_m,
            m.min_gap_follower_m, m.max_ego_speed_m_per_s, m.fast_accelerating_starts,
            m.follower_at_max_speed_starts, m.refused_starts, m.refused_episodes
        );
    }
    let (collisions, losses) = report.failures();
    println!(
        "adversarial search, humans {}, {seconds} s: {collisions} collisions and {losses} \
         certificate losses in {} episodes ({:.0} s)",
        match reacting {
            None => "within the model",
            Some(AfterReaction::AtItsLevel) => {
                "within the model (followers reacting to the brake lights late)"
            }
            Some(AfterReaction::ByItsIdm) => {
                "beyond the model (followers reacting to the brake lights late, then driving by \
                 their IDM)"
            }
        },
        report.episodes(),
        report.seconds
    );
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let path = out.join("findings.json");
    let mut written = serde_json::to_value(&report)?;
    written["certificate"] = serde_json::to_value(&searched)?;
    std::fs::write(&path, serde_json::to_string_pretty(&written)?)
        .with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    if beyond_model {
        if collisions + losses > 0 {
            println!(
                "beyond the model: replay them with `host-tests replay {} --finding K{}{table_flag}`",
                path.display(),
                certificate.flags()
            );
        }
        return Ok(());
    }
    anyhow::ensure!(
        collisions == 0 && losses == 0,
        "the search broke the certificate: {collisions} collisions and {losses} certificate \
         losses; replay them with `host-tests replay {} --finding K{}{table_flag}`",
        path.display(),
        certificate.flags()
    );
    Ok(())
}

/// The certificate and table a search ran with, as `falsify` records them in its findings
/// file, so that `replay` runs the same ones: a finding replayed with another certificate is
/// another episode (one of two authorities replayed in the band came out clean).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct Searched {
    /// `--authorities`.
    authorities: AuthoritiesArg,
    /// `--leader-braking`, m/s^2 (`None`: the table's own).
    leader_braking: Option<f32>,
    /// `--table` (`None`: the firmware's default table).
    table: Option<PathBuf>,
}

impl Searched {
    /// What `replay` runs: each of the certificate's flags and the table as given on its
    /// command line, or else as the search recorded it (the defaults where the file records
    /// nothing), with a note for each given flag that differs from the record and for a file
    /// that records nothing.
    fn replayed(
        recorded: Option<Searched>,
        given: &CertificateArgs,
        table: &Option<PathBuf>,
    ) -> (CertificateArgs, Option<PathBuf>, Vec<String>) {
        let mut notes = Vec::new();
        let Some(r) = recorded else {
            notes.push(
                "the findings file does not record the search's certificate (written before \
                 falsify recorded it): replaying the one given"
                    .to_string(),
            );
            return (given.clone(), table.clone(), notes);
        };
        let authorities = given.authorities.unwrap_or(r.authorities);
        if authorities != r.authorities {
            notes.push(format!(
                "replaying with --authorities {} where the search ran {}",
                authorities.flag(),
                r.authorities.flag()
            ));
        }
        let leader_braking = given
            .leader_braking
            .map_or(r.leader_braking, LeaderBraking::declared);
        if leader_braking != r.leader_braking {
            notes.push(format!(
                "replaying with the leader braking at {leader_braking:?} m/s^2 where the search \
                 ran {:?} (None: the table's own)",
                r.leader_braking
            ));
        }
        let table = table.clone().or(r.table.clone());
        if table != r.table {
            notes.push(format!(
                "replaying with the table {table:?} where the search ran {:?} (None: the \
                 firmware's default)",
                r.table
            ));
        }
        (
            CertificateArgs {
                authorities: Some(authorities),
                leader_braking: leader_braking.map(LeaderBraking::Declared),
            },
            table,
            notes,
        )
    }
}

fn replay(
    findings: &std::path::Path,
    worst: Option<&str>,
    finding: Option<usize>,
    out: &std::path::Path,
    table: &Option<PathBuf>,
    certificate: &CertificateArgs,
) -> Result<()> {
    use host_tests::falsify::Case;
    let text = std::fs::read_to_string(findings)
        .with_context(|| format!("reading {}", findings.display()))?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{} is not JSON", findings.display()))?;
    let pick = |list: &str, k: usize| json.get(list).and_then(|l| l.get(k)).cloned();
    let entry = match (worst, finding) {
        (Some(method), None) => json
            .get("worst")
            .and_then(|l| l.as_array())
            .and_then(|l| {
                l.iter()
                    .find(|f| f["case"]["method"].as_str() == Some(method))
                    .cloned()
            })
            .ok_or_else(|| anyhow::anyhow!("--worst {method}: no such method in the file"))?,
        (None, Some(k)) => pick("findings", k)
            .ok_or_else(|| anyhow::anyhow!("--finding {k}: the file has no finding {k}"))?,
        _ => anyhow::bail!("say which case: --worst METHOD or --finding K"),
    };
    let case: Case = serde_json::from_value(entry["case"].clone())
        .context("the entry's case does not decode")?;
    let recorded = json
        .get("certificate")
        .map(|c| serde_json::from_value::<Searched>(c.clone()))
        .transpose()
        .with_context(|| format!("{}: its `certificate` does not decode", findings.display()))?;
    let (certificate, table, notes) = Searched::replayed(recorded, certificate, table);
    for note in notes {
        println!("note: {note}");
    }
    let (bytes, config) = certificate.resolve(table_bytes(&table)?)?;
    let (table, model) = split_table(bytes)?;
    let setting = search_setting(
        bytes,
        &table,
        model,
        config,
        case.follower_reacts,
        case.follower_after_reaction,
    )?;
    let mut trace = Trace::new();
    let score = setting.run(&case, Some(&mut trace));
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    std::fs::write(
        out.join("trace.json"),
        serde_json::to_string_pretty(&serde_json::json!({
            "case": case,
            "score": score,
            "trace": trace,
        }))?,
    )?;
    host_tests::plots::trace(
        &out.join("trace.png"),
        &format!(
            "replay: {:?} humans, {:?} start (smallest margin {:.3} m)",
            case.method,
            case.start_kind,
            score.min_margin()
        ),
        &trace,
    )?;
    println!(
        "collision at {:?} s, certificate lost {:?}, smallest margin {:.4} m; wrote {}",
        score.collision_time,
        score.certificate_lost,
        score.min_margin(),
        out.display()
    );
    Ok(())
}

/// The campaign's sensors.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum SensorsArg {
    /// Exact measurements, `--latency` periods old.
    Exact,
    /// The datasheets' radars at the firmware's declared error bounds, drawn per episode:
    /// uniform, corner or corner-switching noise, 50-80 ms cycles, 40-100 ms latency with jitter,
    /// 10% of refreshes lost and bursts of losses up to the covered track age.
    Datasheet,
    /// The datasheets' radars as `datasheet` draws them, no refresh lost: the control's own
    /// emergencies apart from the radars' losses.
    DatasheetLossless,
}

/// A cut-in in every episode.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum CutInArg {
    /// None.
    None,
    /// A new leader 8-30 m ahead, -5..0 m/s relative.
    Leader,
    /// A new leader keeping its speed from then on, at UN R157's edge: closing at up to 15 m/s,
    /// from the rule's least gap for avoiding it (at least 2 m) to 10 m past it.
    SteadyLeader,
    /// A new follower 3-10 m behind, closing at 0..5 m/s.
    Follower,
}

/// The campaign's arguments.
#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
struct CampaignArgs {
    /// Episodes per (leader, follower) group.
    #[arg(long, default_value_t = 500)]
    episodes: usize,
    /// Simulated seconds per episode.
    #[arg(long, default_value_t = 120.0)]
    seconds: f32,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The sensors.
    #[arg(long, value_enum, default_value_t = SensorsArg::Datasheet)]
    sensors: SensorsArg,
    /// With `--sensors exact`: the measurements' latency, control periods (at most 50, 1 s).
    #[arg(long, default_value_t = 0)]
    latency: u32,
    /// A cut-in in every episode (outside the model: reported apart).
    #[arg(long, value_enum, default_value_t = CutInArg::None)]
    cut_in: CutInArg,
    /// The ego actuator's dead time, ms (the firmware's default covers up to 100).
    #[arg(long, default_value_t = 100.0)]
    dead_time_ms: f32,
    /// The ego actuator's first-order lag time constant, s (the firmware's default covers
    /// up to 0.3).
    #[arg(long, default_value_t = 0.3)]
    lag: f32,
    /// Output folder.
    #[arg(long, default_value = "out/campaign")]
    out: PathBuf,
    /// A table file to run instead of the firmware's default table.
    #[arg(long, value_name = "FILE")]
    table: Option<PathBuf>,
    #[command(flatten)]
    certificate: CertificateArgs,
}

fn campaign(args: CampaignArgs) -> Result<()> {
    use host_tests::campaign::{run_campaign, CampaignSettings, FREE_ROAD, NEEDLESS_REPORTED_S};
    let CampaignArgs {
        episodes,
        seconds,
        seed,
        sensors,
        latency,
        cut_in,
        dead_time_ms,
        lag,
        out,
        table,
        certificate,
    } = args;
    let (bytes, config) = certificate.resolve(table_bytes(&table)?)?;
    anyhow::ensure!(
        latency == 0 || sensors == SensorsArg::Exact,
        "--latency is for --sensors exact; the datasheet sensors draw their own"
    );
    let settings = CampaignSettings {
        episodes,
        seconds,
        seed,
        sensing: match sensors {
            SensorsArg::Exact => Sensing::Fixed(SensorModel::exact_with_latency(latency)),
            SensorsArg::Datasheet => Sensing::Datasheet,
            SensorsArg::DatasheetLossless => Sensing::DatasheetLossless,
        },
        cut_in: match cut_in {
            CutInArg::None => None,
            CutInArg::Leader => Some(CutInKind::Leader),
            CutInArg::SteadyLeader => Some(CutInKind::SteadyLeader),
            CutInArg::Follower => Some(CutInKind::Follower),
        },
        actuator: ActuatorModel {
            dead_time: dead_time_ms * 1e-3,
            lag,
        },
        config,
    };
    settings
        .check()
        .map_err(|e| anyhow::anyhow!("--{} {}", e.field.replace('_', "-"), e.reason))?;
    let (table, _) = split_table(bytes)?;
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let bar = ProgressBar::new((host_tests::campaign::GROUPS.len() * episodes) as u64);
    bar.set_style(
        ProgressStyle::with_template("[{bar:40}] {pos}/{len} episodes ({elapsed}, eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    println!(
        "| leader | follower | in model | episodes | collisions | of them unavoidable | certificate losses (nominal/override/min-risk/uncertified; front/rear/speed/domain) | min margin [m] (front, rear) | min gap front [m] | min gap rear [m] | override | uncertified min-risk periods | fallback periods (episodes) | oldest track [s] (front, rear) | leader stops | standstill starts | max jerk [m/s^3] | ISO 15622 held (episodes whose leader braked at most 3.5 m/s^2, engaged without an emergency) | worst ISO ratio there | of them from starts the comfort band certifies: ISO 15622 held (emergency periods) | emergency periods: engagement / cut-in / uncertified truth / certified truth [of which by the comfort band alone; begun in a radar dropout] (engagements that were one) |"
    );
    println!(
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    let mut plotted: Result<()> = Ok(());
    let report = run_campaign(
        &table,
        bytes,
        &settings,
        &mut |summary, worst| {
            let l = summary.certificate_losses_by_mode;
            bar.suspend(|| {
                println!(
                    "| {:?} | {:?} | {} | {} | {} | {} | {} ({}/{}/{}/{}; {}/{}/{}/{}) | {:.4} ({:.4}, {:.4}) | {:.2} | {:.2} | {:.3} | {} | {} ({}) | {:.2}, {:.2} | {:.1} | {} | {:.0} | {} of {} | {:.2} | {} of {} ({}) | {} / {} / {} / {} [{}; {}] ({}) |",
                    summary.leader,
                    summary.follower,
                    summary.in_model,
                    summary.episodes,
                    summary.collisions,
                    summary.collisions_unavoidable,
                    summary.certificate_losses,
                    l.nominal,
                    l.r#override,
                    l.minimum_risk,
                    l.uncertified,
                    l.front,
                    l.rear,
                    l.speed,
                    l.domain,
                    summary.min_margin,
                    summary.min_front_margin,
                    summary.min_rear_margin,
                    summary.min_gap_leader,
                    summary.min_gap_follower,
                    summary.mean_override_share,
                    summary.uncertified_minimum_risk_periods,
                    summary.fallback_periods,
                    summary.fallback_episodes,
                    summary.max_track_age[0],
                    summary.max_track_age[1],
                    summary.mean_leader_stops,
                    summary.standstill_starts,
                    summary.max_jerk,
                    summary.iso_scope.1,
                    summary.iso_scope.0,
                    summary.iso_worst_in_scope,
                    summary.iso_scope_comfort_start.1,
                    summary.iso_scope_comfort_start.0,
                    summary.iso_scope_comfort_start.2.total(),
                    summary.emergencies.engagement,
                    summary.emergencies.cut_in,
                    summary.emergencies.uncertified_truth,
                    summary.emergencies.certified_truth,
                    summary.emergencies.comfort_certified_truth,
                    summary.emergencies.dropout,
                    summary.engaged_in_emergency
                )
            });
            // The group's episode with the smallest margin, plotted.
            let mut trace = Trace::new();
            if summary.episodes > 0 && run_episode(&table, bytes, worst, Some(&mut trace)).is_some()
            {
                let name =
                    format!("worst_{:?}_{:?}.png", summary.leader, summary.follower).to_lowercase();
                let drawn = host_tests::plots::trace(
                    &out.join(name),
                    &format!(
                        "smallest margin: {:?} leader, {:?} follower (seed {})",
                        summary.leader, summary.follower, summary.worst_seed
                    ),
                    &trace,
                );
                if plotted.is_ok() {
                    plotted = drawn;
                }
            }
        },
        &|| bar.inc(1),
    );
    bar.finish_and_clear();
    plotted?;
    if settings.cut_in.is_some() {
        println!();
        println!("| leader | follower | cut-ins | first track after [s] (mean, max) | recognised at once | front uncertified | of those answered within one period | their first answer, mean [m/s^2] | mean hardest command [m/s^2] | braked harder than the band (episodes) | collisions | of them hit from behind | of them unavoidable (at beta) | R157 requires avoiding | collisions unavoidable at the emergency authority | of the others, hit from behind there | preventable, not prevented | of those, through the declared sensors too |");
        println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        for summary in &report.groups {
            if let Some(c) = summary.cut_ins {
                println!(
                    "| {:?} | {:?} | {} | {:.3}, {:.3} | {} | {} | {} | {:.2} | {:.2} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    summary.leader,
                    summary.follower,
                    c.episodes,
                    c.delivered_after_mean,
                    c.delivered_after_max,
                    c.recognised_at_once,
                    c.front_uncertified,
                    c.answered_within_one_period,
                    c.mean_first_answer,
                    c.mean_hardest_command,
                    summary.below_band_episodes,
                    c.collisions,
                    c.collisions_behind,
                    c.unavoidable,
                    c.r157_requires_avoiding,
                    c.unavoidable_at_emergency,
                    c.hit_from_behind_at_emergency,
                    c.preventable_not_prevented,
                    c.preventable_through_the_sensors_not_prevented
                );
            }
        }
    }
    std::fs::write(
        out.join("campaign.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    let t = &report.totals;
    println!(
        "certified starts, humans within the model, {seconds} s: {} collisions \
         ({} after the humans alone had made one unavoidable), \
         {} certificate losses and {} uncertified minimum-risk \
         periods ({} periods of the certified fallback) in {} episodes",
        t.collisions,
        t.collisions_unavoidable,
        t.certificate_losses,
        t.uncertified_minimum_risk_periods,
        t.fallback_periods,
        t.in_model_episodes
    );
    let e = &t.emergencies;
    println!(
        "emergency periods there: {} at engagement, {} after a cut-in, {} with the true state \
         uncertified, {} with it certified (made by the measurement or the delays' bounds), \
         {} of those with it certified by the comfort band alone, {} in runs begun in a radar \
         dropout; {} periods in {} episodes braked harder than the band",
        e.engagement,
        e.cut_in,
        e.uncertified_truth,
        e.certified_truth,
        e.comfort_certified_truth,
        e.dropout,
        t.below_band_periods,
        t.below_band_episodes
    );
    let comfort_start = report.groups.iter().filter(|g| g.in_model).fold(
        (0, 0, EmergencyCauses::default()),
        |(n, held, causes), g| {
            let (gn, gheld, gcauses) = g.iso_scope_comfort_start;
            (n + gn, held + gheld, causes.add(&gcauses))
        },
    );
    println!(
        "in ISO 15622's scope there (leaders within 3.5 m/s^2), from starts the comfort band \
         certifies: ISO 15622 held in {} of {}, {} emergency periods ({} of them in runs begun in \
         a radar dropout: a track older than it would be without the radar's losses)",
        comfort_start.1,
        comfort_start.0,
        comfort_start.2.total(),
        comfort_start.2.dropout
    );
    let needless = &t.needless;
    println!(
        "braking the road did not ask for there (engaged, the leader more than {} m ahead and \
         {} m/s faster): beyond the lights' deceleration ({} m/s^2) for more than {} s in {} \
         episodes (the longest {:.1} s, seed {}), at a standstill for more than {} s in {} (the \
         longest {:.1} s, seed {})",
        FREE_ROAD.0,
        FREE_ROAD.1,
        settings.config.certificate.emergency.lights_deceleration,
        NEEDLESS_REPORTED_S,
        needless.episodes[0],
        needless.braking.0,
        needless.braking.1,
        NEEDLESS_REPORTED_S,
        needless.episodes[1],
        needless.standstill.0,
        needless.standstill.1
    );
    if settings.cut_in.is_some() {
        let emergency = settings.config.certificate.emergency;
        println!(
            "cut-ins: {}; {} not answered within one period of the new track \
             while the front was uncertified; {} collisions the humans had not made \
             unavoidable, {} with the follower; at the emergency authority ({} m/s^2 built up \
             at {} m/s^3 from the band's floor) {} unavoidable ahead, {} hit from behind \
             instead by the follower as it drove ({} by the IDM at its closest time gap \
             answering at once, {} by the certificate's follower reacting after {} s); {} \
             cut-ins R157 requires avoiding (the new car keeping its speed); {} collisions \
             preventable (by R157's rule or at the emergency authority) but not prevented, {} \
             of them through the declared sensors too",
            t.cut_ins,
            t.cut_ins_answered_late,
            t.cut_in_collisions_avoidable,
            t.cut_in_collisions_behind,
            emergency.braking.level,
            emergency.braking.jerk,
            t.cut_in_collisions_unavoidable_at_emergency,
            t.cut_in_collisions_hit_from_behind_at_emergency,
            t.cut_in_collisions_hit_from_behind_at_emergency_answered[0],
            t.cut_in_collisions_hit_from_behind_at_emergency_answered[1],
            emergency.follower_reaction_time,
            t.cut_ins_r157,
            t.cut_in_collisions_preventable,
            t.cut_in_collisions_preventable_through_the_sensors
        );
    }
    println!("wrote {}", out.display());
    if let Some(failure) = report.failure() {
        anyhow::bail!("{failure}");
    }
    Ok(())
}

/// The traces the suite plots (a part of the name).
const PLOTTED: [&str; 4] = [
    "lead accel and decel at 0.5m/s^2 every 2s",
    "stop and go with 1m/s2 lead decel and accel, with full stops",
    "CCRb: both 50 km/h, 40 m apart, target braking at 6",
    "steady following at 30",
];

fn scenarios(
    out: &std::path::Path,
    only: Option<&str>,
    certificate: &CertificateArgs,
) -> Result<()> {
    use host_tests::scenarios::{run, suite};
    let (bytes, config) = certificate.resolve(firmware::DEFAULT_TABLE)?;
    let (table, _) = split_table(bytes)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let suite: Vec<_> = suite()
        .into_iter()
        .filter(|s| only.is_none_or(|o| s.name.contains(o)))
        .collect();
    anyhow::ensure!(
        !suite.is_empty(),
        "--only {:?} matches no scenario (`scenarios` without it lists every run)",
        only.unwrap_or_default()
    );
    let started = std::time::Instant::now();
    let bang_bang = firmware::Config::bang_bang();
    let bang_bang = firmware::Config {
        certificate: firmware::CertificateConfig {
            authorities: config.certificate.authorities,
            ..bang_bang.certificate
        },
        ..bang_bang
    };
    // The paper's policy brakes at once, which two authorities do not argue with: the firmware
    // refuses that configuration, and the suite runs the graded policy alone.
    let bang_bang = firmware::Controller::new(bytes, bang_bang)
        .table()
        .is_some()
        .then_some(bang_bang);
    let policies: Vec<firmware::Config> = [Some(config), bang_bang].into_iter().flatten().collect();
    let mut runs = Vec::new();
    for scenario in &suite {
        for config in &policies {
            for follower in [false, true] {
                runs.push((scenario, *config, follower));
            }
        }
    }
    use rayon::prelude::*;
    let results: Vec<_> = runs
        .par_iter()
        .map(|(scenario, config, follower)| {
            let plotted = PLOTTED.iter().any(|p| scenario.name.contains(p))
                && *follower
                && config.certificate.override_policy == firmware::OverridePolicy::Graded;
            let mut trace = plotted.then(Trace::new);
            let result = run(&table, bytes, *config, scenario, *follower, trace.as_mut());
            (result, trace, scenario.name.clone())
        })
        .collect();
    println!(
        "| scenario | source | follower | policy | start gap [m] (source's) | jerk/limit | decel/limit | accel/limit | mode switches | override periods | emergency periods | min gap [m] | needless braking / standing [s] | own check | result |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut failed_graded = 0;
    let mut failed_bang = 0;
    let mut report = Vec::new();
    for (k, (result, trace, name)) in results.into_iter().enumerate() {
        let r = result.context("the default table is not a split table")?;
        let pass = r.passed();
        if !pass {
            if r.policy == "graded" {
                failed_graded += 1;
            } else {
                failed_bang += 1;
            }
        }
        let gap = match (r.start_gap_m, r.source_gap_m) {
            (Some(s), Some(g)) if (s - g).abs() > 0.01 => format!("{s:.1} ({g:.0})"),
            (Some(s), _) => format!("{s:.1}"),
            _ => "-".into(),
        };
        let check = match r.check {
            host_tests::scenarios::Check::None => "-".to_string(),
            c => format!(
                "{c:?} {} {:?}",
                if r.check_holds { "holds" } else { "FAILS" },
                r.check_figures
                    .iter()
                    .map(|x| (x * 100.0).round() / 100.0)
                    .collect::<Vec<_>>()
            ),
        };
        println!(
            "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {} | {} | {} | {:.1} | {:.1} / {:.1} | {} | {} |",
            r.name,
            if r.source.starts_with("openpilot") {
                "openpilot"
            } else if r.source.starts_with("Euro") {
                "Euro NCAP"
            } else {
                "hjacc"
            },
            if r.follower { "IDM" } else { "none" },
            r.policy,
            gap,
            r.iso.jerk,
            r.iso.deceleration,
            r.iso.acceleration,
            r.mode_switches,
            r.override_periods,
            r.emergency_periods,
            r.min_gap_leader_m.min(999.0),
            r.needless.braking,
            r.needless.standstill,
            check,
            if pass {
                "pass".to_string()
            } else if let Some(why) = &r.engagement_refused {
                format!("engagement refused ({why})")
            } else if r.comfort_scope || r.collided || r.certificate_lost {
                "FAIL".to_string()
            } else {
                "fail (outside comfort scope)".to_string()
            },
        );
        if let Some(trace) = trace {
            let file = out.join(format!("trace-{k:02}.png"));
            host_tests::plots::trace(&file, &name, &trace)?;
            println!("  trace: {}", file.display());
        }
        report.push(r);
    }
    // Per source and policy: docs/closed-loop.md's table (a test compares them).
    println!();
    println!("{}", host_tests::scenarios::SUMMARY_HEADER);
    for row in host_tests::scenarios::summary_rows(&report) {
        println!("{row}");
    }
    let json = serde_json::to_string_pretty(&report)?;
    std::fs::write(out.join("scenarios.json"), json)?;
    let bang_bang = if bang_bang.is_some() {
        format!("{failed_bang} failed (the paper's policy breaks ISO 15622's jerk limit by design)")
    } else {
        "not run (the firmware refuses it with two authorities)".to_string()
    };
    // Braking and standing the road did not ask for ([`host_tests::world::Needless`]): the
    // runs with a stretch over the campaign's reporting threshold.
    let over = |i: usize| report.iter().filter(|r| r.needless.reported()[i]).count();
    println!(
        "{} runs in {:.1} s; graded: {} failed, bang-bang: {}; braking / standing on a free road for more than {} s in {} / {} runs; {}",
        report.len(),
        started.elapsed().as_secs_f32(),
        failed_graded,
        bang_bang,
        host_tests::campaign::NEEDLESS_REPORTED_S,
        over(0),
        over(1),
        out.join("scenarios.json").display()
    );
    anyhow::ensure!(
        failed_graded == 0,
        "{failed_graded} runs of the graded policy failed (a collision, a loss, ISO 15622 in scope, or their own check)"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The replay hint repeats the search's certificate: nothing for the defaults, the flags
    /// as given otherwise (without them a two-authority finding replayed in the band).
    #[test]
    fn the_certificate_flags_are_the_command_lines() {
        let band = CertificateArgs {
            authorities: None,
            leader_braking: None,
        };
        assert_eq!(band.flags(), "");
        let two = CertificateArgs {
            authorities: Some(AuthoritiesArg::Two),
            leader_braking: Some(LeaderBraking::Declared(9.8)),
        };
        assert_eq!(two.flags(), " --authorities two --leader-braking 9.8");
        let parsed = Args::try_parse_from(
            ["host-tests", "replay", "f.json", "--finding", "0"]
                .into_iter()
                .chain(two.flags().split_whitespace()),
        );
        assert!(parsed.is_ok(), "the flags parse back");
        let parse = |value: &str| {
            Args::try_parse_from(["host-tests", "scenarios", "--leader-braking", value])
        };
        assert!(parse("table").is_ok() && parse("9.8").is_ok());
        let refused = parse("soft")
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(refused.contains("`table` for the table's own"), "{refused}");
    }

    /// `replay` runs the certificate and table the search recorded, unless its command line
    /// says otherwise (with a note for each difference), and says so where the file records
    /// none; the record is what `falsify` writes and decodes back.
    #[test]
    fn a_replay_runs_the_searchs_certificate() {
        let searched = Searched {
            authorities: AuthoritiesArg::Two,
            leader_braking: Some(9.8),
            table: Some(PathBuf::from("t.bin")),
        };
        let written = serde_json::to_value(&searched).unwrap();
        assert_eq!(written["authorities"], "two");
        let recorded: Searched = serde_json::from_value(written).unwrap();
        assert_eq!(recorded, searched);
        let nothing = CertificateArgs {
            authorities: None,
            leader_braking: None,
        };
        let (c, t, notes) = Searched::replayed(Some(searched.clone()), &nothing, &None);
        assert_eq!(c.authorities(), AuthoritiesArg::Two);
        assert_eq!(c.leader_braking, Some(LeaderBraking::Declared(9.8)));
        assert_eq!(t, searched.table);
        assert!(notes.is_empty(), "{notes:?}");
        let band = CertificateArgs {
            authorities: Some(AuthoritiesArg::Band),
            leader_braking: None,
        };
        let (c, _, notes) = Searched::replayed(Some(searched.clone()), &band, &None);
        assert_eq!(c.authorities(), AuthoritiesArg::Band);
        assert_eq!(c.leader_braking, Some(LeaderBraking::Declared(9.8)));
        assert_eq!(notes.len(), 1, "{notes:?}");
        // `--leader-braking table` undoes the search's declaration, with its note.
        let own = CertificateArgs {
            authorities: None,
            leader_braking: Some(LeaderBraking::Table),
        };
        let (c, _, notes) = Searched::replayed(Some(searched.clone()), &own, &None);
        assert_eq!(c.leader_braking, None);
        assert_eq!(c.flags(), " --authorities two");
        assert_eq!(notes.len(), 1, "{notes:?}");
        let (c, t, notes) = Searched::replayed(None, &nothing, &None);
        assert_eq!((c, t), (nothing, None));
        assert_eq!(notes.len(), 1, "{notes:?}");
    }
}
