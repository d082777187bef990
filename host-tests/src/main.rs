//! `cargo run -p host-tests --release -- campaign [--episodes N] [--seconds S] [--out DIR]`
//!
//! Runs every (start, leader, follower) group with the firmware's default table, prints a table
//! of the results, writes `DIR/campaign.json` and PNG plots of the worst episode of each group
//! that collided or came closest.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use host_tests::campaign::{run_episode, run_group, Episode, Trace};
use host_tests::{Follower, Leader, SensorModel, Start};
use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;
use table_format::Table;

#[derive(Parser)]
#[command(about = "Closed-loop campaigns of the hjacc firmware")]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Runs the safety campaign.
    Campaign {
        /// Episodes per (start, leader, follower) group.
        #[arg(long, default_value_t = 500)]
        episodes: usize,
        /// Simulated seconds per episode.
        #[arg(long, default_value_t = 30.0)]
        seconds: f32,
        /// First seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Gap noise (standard deviation, m); speed noise is a tenth of it per metre.
        #[arg(long, default_value_t = 0.0)]
        noise: f32,
        /// Sensor latency, control periods.
        #[arg(long, default_value_t = 0)]
        latency: u32,
        /// Probability of a dropped measurement per period.
        #[arg(long, default_value_t = 0.0)]
        dropout: f32,
        /// Output folder.
        #[arg(long, default_value = "out/campaign")]
        out: PathBuf,
        /// A table file to run instead of the firmware's default table.
        #[arg(long, value_name = "FILE")]
        table: Option<PathBuf>,
    },
}

const LEADERS: [Leader; 4] = [
    Leader::HardBrake,
    Leader::StopAndGo,
    Leader::Random,
    Leader::WorstCase,
];
const FOLLOWERS: [Follower; 5] = [
    Follower::IdmFixed,
    Follower::IdmRandom,
    Follower::IdmSwitching,
    Follower::IdmWorstCase,
    Follower::Unbounded,
];

fn plot_trace(path: &std::path::Path, title: &str, trace: &Trace) -> Result<()> {
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let (upper, lower) = root.split_vertically(380);
    let t_max = trace.last().map_or(1.0, |p| p.0).max(0.1);
    let g_max = trace.iter().map(|p| p.1.max(p.2)).fold(1.0f32, f32::max) * 1.1;
    let mut chart = ChartBuilder::on(&upper)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(50)
        .build_cartesian_2d(0f32..t_max, 0f32..g_max)?;
    chart.configure_mesh().y_desc("gap [m]").draw()?;
    chart
        .draw_series(LineSeries::new(
            trace.iter().map(|p| (p.0, p.1)),
            BLUE.stroke_width(2),
        ))?
        .label("gap to leader")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], BLUE.stroke_width(2)));
    chart
        .draw_series(LineSeries::new(
            trace.iter().map(|p| (p.0, p.2)),
            RED.stroke_width(2),
        ))?
        .label("gap to follower")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], RED.stroke_width(2)));
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()?;
    let mut chart = ChartBuilder::on(&lower)
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0f32..t_max, -4.5f32..2.5)?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc("ego command [m/s^2]")
        .draw()?;
    chart.draw_series(LineSeries::new(
        trace.iter().map(|p| (p.0, p.3)),
        BLACK.stroke_width(2),
    ))?;
    chart.draw_series(trace.iter().filter(|p| p.4 != 0).map(|p| {
        Circle::new(
            (p.0, p.3),
            2,
            if p.4 == 1 {
                GREEN.filled()
            } else {
                MAGENTA.filled()
            },
        )
    }))?;
    root.present()?;
    Ok(())
}

fn main() -> Result<()> {
    let Command::Campaign {
        episodes,
        seconds,
        seed,
        noise,
        latency,
        dropout,
        out,
        table,
    } = Args::parse().command;
    let bytes: &'static [u8] = match &table {
        Some(path) => std::fs::read(path)
            .with_context(|| format!("reading {}", path.display()))?
            .leak(),
        None => firmware::DEFAULT_TABLE,
    };
    let table =
        Table::parse(bytes).map_err(|e| anyhow::anyhow!("the table does not parse: {e}"))?;
    // The humans' worst cases and the start sampler read the 4-D relative state, as the
    // firmware does (it refuses other tables).
    anyhow::ensure!(
        table.dims() == 4,
        "the campaign runs 4-D three-car tables (the firmware's); this one has {} axes",
        table.dims()
    );
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let sensors = SensorModel {
        gap_noise: noise,
        speed_noise: noise * 0.1,
        latency_periods: latency,
        dropout,
    };
    let groups: Vec<(Start, Leader, Follower)> = [Start::Certified, Start::JustOutside]
        .into_iter()
        .flat_map(|s| {
            LEADERS
                .into_iter()
                .flat_map(move |l| FOLLOWERS.into_iter().map(move |f| (s, l, f)))
        })
        .collect();
    let bar = ProgressBar::new((groups.len() * episodes) as u64);
    bar.set_style(
        ProgressStyle::with_template("[{bar:40}] {pos}/{len} episodes ({elapsed}, eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut summaries = Vec::new();
    println!(
        "| start | leader | follower | episodes | collisions | of them unavoidable | fraction | min gap front | min gap rear | override | min-risk | uncertified episodes | max jerk |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (i, (start, leader, follower)) in groups.iter().enumerate() {
        let template = Episode {
            start: *start,
            leader: *leader,
            follower: *follower,
            seconds,
            sensors,
            seed: seed + (i as u64) * 1_000_000,
        };
        let (summary, _) = run_group(&table, bytes, template, episodes, &|| bar.inc(1));
        bar.suspend(|| {
            println!(
                "| {:?} | {:?} | {:?} | {} | {} | {} | {:.4} | {:.2} | {:.2} | {:.3} | {:.3} | {:.3} | {:.0} |",
                summary.start,
                summary.leader,
                summary.follower,
                summary.episodes,
                summary.collisions,
                summary.collisions_unavoidable,
                summary.collision_fraction,
                summary.min_gap_leader,
                summary.min_gap_follower,
                summary.mean_override_share,
                summary.mean_minimum_risk_share,
                summary.uncertified_episodes,
                summary.max_jerk
            )
        });
        let mut trace = Trace::new();
        let worst = Episode {
            seed: summary.worst_seed,
            ..template
        };
        if run_episode(&table, bytes, &worst, Some(&mut trace)).is_some() {
            let name = format!("worst_{:?}_{:?}_{:?}.png", start, leader, follower).to_lowercase();
            plot_trace(
                &out.join(name),
                &format!("worst episode: {start:?} start, {leader:?} leader, {follower:?} follower (seed {})", summary.worst_seed),
                &trace,
            )?;
        }
        summaries.push(summary);
    }
    bar.finish_and_clear();
    let json = serde_json::to_string_pretty(&serde_json::json!({
        "episodes_per_group": episodes,
        "seconds": seconds,
        "sensors": sensors,
        "groups": summaries,
    }))?;
    std::fs::write(out.join("campaign.json"), json)?;
    let model: Vec<_> = summaries
        .iter()
        .filter(|s| s.start == Start::Certified && s.follower != Follower::Unbounded)
        .collect();
    let episodes_model: usize = model.iter().map(|s| s.episodes).sum();
    let collisions_model: usize = model.iter().map(|s| s.collisions).sum();
    let unavoidable_model: usize = model.iter().map(|s| s.collisions_unavoidable).sum();
    println!(
        "certified starts, humans within the model: {collisions_model} collisions in {episodes_model} episodes \
         ({unavoidable_model} of them after the humans alone had made one unavoidable)"
    );
    println!("wrote {}", out.display());
    Ok(())
}
