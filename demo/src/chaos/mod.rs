//! `lewis demo --chaos`: the Challenge mission again and again, for as long as asked, while
//! random providers are killed, stalled, frozen, garbled and put out of service at random
//! times ([`schedule`], struck live by [`striker`]); what the machine pays for it is read
//! from `/proc` and `/dev/shm` as it goes ([`resources`]).
//!
//! Each mission runs in a namespace of its own, with its own recording, and is judged as
//! the demo's is. A mission that fails keeps its folder (the recording, the mission's
//! records, its faults) and is lived again with the same faults (closed loop: the
//! recorded deaths applied again, the harness's faults given as `--inject-fault`), to say
//! whether the replay shows the same failure; the report names the command. A mission that
//! succeeds leaves only its line in the report: an hour of recordings would fill a disk.

pub mod picture;
pub mod resources;
pub mod schedule;
pub mod striker;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

use lewis_launch::Launch;
use lewis_recording::RecordingFiles;
use lewis_recording::info::{InfoOptions, inspect};
use lewis_replay::fault::{FaultKind, FaultSpec};
use lewis_replay::lockstep::Programs;
use lewis_replay::resim::{ReplayOptions, ServiceSelection, replay_with};
use lewis_runtime::ipc::Namespace;
use lewis_sequencer::session::load_mission;
use lewis_service::ServiceRegistry;
use serde::Serialize;

use crate::{DemoError, fresh_dir, load_robot, unattended_launch, with_seed, write_error};
use resources::{UseSample, UseSampler, entries_with_prefix, slope};
use schedule::{ChaosFault, ChaosPlan};
use striker::{BrokerCounts, Striker, Struck};

/// Where a chaos run writes by default.
pub const OUT_DIR: &str = "logs/chaos";

/// What to run, for how long, and where to write.
#[derive(Debug, Clone)]
pub struct ChaosOptions {
    /// The robot file (`robots/sim.toml`).
    pub robot: PathBuf,
    /// The mission script (`robots/missions/challenge.seq`).
    pub script: PathBuf,
    /// The seed of the faults and of the simulated devices: mission `i` draws its faults
    /// from it and seeds its devices with `seed + 100 i`.
    pub seed: u64,
    /// How long the run lasts: the mission running then is stopped, and counted as cut
    /// short rather than judged.
    pub duration: Duration,
    /// The output folder: `chaos.json`, and a folder per failed mission.
    pub out: PathBuf,
    /// The `lewis` binary (for the services, the recorder and the programs).
    pub lewis_exe: PathBuf,
    /// How often the machine's use is read.
    pub sample_every: Duration,
    /// Live every failed mission again with its faults, to see whether the replay fails
    /// the same way.
    pub reproduce: bool,
}

/// One mission of the run.
#[derive(Debug, Clone, Serialize)]
pub struct MissionResult {
    /// Its place in the run, from 1.
    pub number: u32,
    /// The seed of its devices.
    pub device_seed: u64,
    /// Whether it succeeded.
    pub succeeded: bool,
    /// Whether the run's end stopped it before it was over (then it is not judged: neither
    /// a success nor a failure).
    pub cut_short: bool,
    /// The verdict's reason.
    pub reason: String,
    /// The states it went through.
    pub states: Vec<String>,
    /// From its start to its end, in seconds (the sequencer's records).
    pub duration_s: f64,
    /// Each fault of its schedule, as it went.
    pub faults: Vec<Struck>,
    /// What the broker did.
    pub broker: BrokerCounts,
    /// Messages in its recording.
    pub recorded: u64,
    /// Messages the recorder counted lost.
    pub lost: u64,
    /// Entries of its namespace left in `/dev/shm` and `/tmp/iceoryx2` once it was over.
    pub leftovers: u64,
    /// Its folder, kept when it failed.
    pub kept: Option<PathBuf>,
    /// The command that lives it again with the same faults, when it failed.
    pub replay_command: Option<String>,
    /// Whether that replay failed too (`None`: not tried, or it could not run; see
    /// `replay_error`).
    pub replay_fails_too: Option<bool>,
    /// Why the replay could not run, if it could not.
    pub replay_error: Option<String>,
}

impl MissionResult {
    /// Whether it failed although the broker always had a provider to give (it never
    /// asked for help): the failures chaos is meant to find.
    #[must_use]
    pub fn failed_with_providers_left(&self) -> bool {
        self.failed() && self.broker.help_for.is_empty()
    }

    /// Whether it failed (a mission cut short by the run's end did not).
    #[must_use]
    pub fn failed(&self) -> bool {
        !self.succeeded && !self.cut_short
    }
}

/// How one kind of process used memory over the run.
#[derive(Debug, Clone, Serialize)]
pub struct MemoryTrend {
    /// The process (a service's name, `record`, `program`, or `lewis` for this one).
    pub name: String,
    /// Its peak memory (PSS) in the first mission it ran in, KiB.
    pub first_kib: u64,
    /// In the last, KiB.
    pub last_kib: u64,
    /// The slope of its per-mission peak, KiB a mission (`None`: fewer than two).
    pub kib_per_mission: Option<f64>,
}

/// The whole run.
#[derive(Debug, Clone, Serialize)]
pub struct ChaosReport {
    /// The seed.
    pub seed: u64,
    /// How long it ran, in seconds.
    pub ran_s: f64,
    /// Each mission.
    pub missions: Vec<MissionResult>,
    /// The machine's use, read every `sample_every`.
    pub samples: Vec<UseSample>,
    /// Memory by process over the missions.
    pub memory: Vec<MemoryTrend>,
    /// The slope of the run's open descriptors (peak per mission), a mission.
    pub fds_per_mission: Option<f64>,
    /// The slope of the machine's shared-memory entries (peak per mission), a mission.
    pub shm_entries_per_mission: Option<f64>,
    /// The run's mean CPU, in % of one core.
    pub mean_cpu_percent: f64,
}

impl ChaosReport {
    /// Missions that succeeded.
    #[must_use]
    pub fn succeeded(&self) -> usize {
        self.missions.iter().filter(|m| m.succeeded).count()
    }

    /// Missions judged: all but one the run's end cut short.
    #[must_use]
    pub fn judged(&self) -> usize {
        self.missions.iter().filter(|m| !m.cut_short).count()
    }

    /// Messages lost over the run.
    #[must_use]
    pub fn lost(&self) -> u64 {
        self.missions.iter().map(|m| m.lost).sum()
    }

    /// Entries left in shared memory over the run.
    #[must_use]
    pub fn leftovers(&self) -> u64 {
        self.missions.iter().map(|m| m.leftovers).sum()
    }

    /// The lines that close the run: totals, what the machine paid, the failures.
    #[must_use]
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let n = self.judged();
        let sum = |f: fn(&MissionResult) -> u64| self.missions.iter().map(f).sum::<u64>();
        let struck = sum(|m| m.faults.iter().filter(|f| f.struck_ns.is_some()).count() as u64);
        let _ = writeln!(
            s,
            "chaos: {} of {n} missions succeeded ({:.0}%) in {} with seed {}",
            self.succeeded(),
            if n == 0 {
                0.0
            } else {
                100.0 * self.succeeded() as f64 / n as f64
            },
            minutes(self.ran_s),
            self.seed
        );
        let _ = writeln!(
            s,
            "  {struck} faults struck; {} restarts, {} failovers, {} retries, {} services given up; clients blind {:.1} s in all",
            sum(|m| u64::from(m.broker.restarts)),
            sum(|m| u64::from(m.broker.failovers)),
            sum(|m| u64::from(m.broker.retries)),
            sum(|m| u64::from(m.broker.failed)),
            self.missions.iter().map(|m| m.broker.blind_ns).sum::<i64>() as f64 / 1e9
        );
        let _ = writeln!(
            s,
            "  {} messages recorded, {} lost; {} entries left in shared memory",
            sum(|m| m.recorded),
            self.lost(),
            self.leftovers()
        );
        let _ = writeln!(
            s,
            "  machine: CPU {:.0}% of a core on average; descriptors {}, shared-memory entries {} a mission",
            self.mean_cpu_percent,
            per_mission(self.fds_per_mission),
            per_mission(self.shm_entries_per_mission)
        );
        let mut memory: Vec<&MemoryTrend> = self.memory.iter().collect();
        memory.sort_by_key(|m| std::cmp::Reverse(m.last_kib));
        let shown: Vec<String> = memory
            .iter()
            .take(6)
            .map(|m| {
                format!(
                    "{} {:.1} -> {:.1} MiB ({})",
                    m.name,
                    m.first_kib as f64 / 1024.0,
                    m.last_kib as f64 / 1024.0,
                    m.kib_per_mission.map_or_else(
                        || "one mission".to_owned(),
                        |k| format!("{k:+.0} KiB a mission")
                    )
                )
            })
            .collect();
        if !shown.is_empty() {
            let _ = writeln!(
                s,
                "  memory (PSS, peak, first -> last mission): {}",
                shown.join(", ")
            );
        }
        let unexpected = self
            .missions
            .iter()
            .filter(|m| m.failed_with_providers_left())
            .count();
        if self.missions.iter().any(MissionResult::failed) {
            let _ = writeln!(
                s,
                "  failed with a provider of everything left: {unexpected} (the others lost every provider of {})",
                {
                    let mut needs: Vec<&str> = self
                        .missions
                        .iter()
                        .filter(|m| m.failed())
                        .flat_map(|m| m.broker.help_for.iter().map(String::as_str))
                        .collect();
                    needs.sort_unstable();
                    needs.dedup();
                    if needs.is_empty() {
                        "nothing".to_owned()
                    } else {
                        needs.join(", ")
                    }
                }
            );
        }
        s
    }
}

fn per_mission(slope: Option<f64>) -> String {
    slope.map_or_else(|| "n/a".to_owned(), |k| format!("{k:+.2}"))
}

fn minutes(s: f64) -> String {
    if s >= 120.0 {
        format!("{:.0} min", s / 60.0)
    } else {
        format!("{s:.0} s")
    }
}

/// The line of one mission, as soon as it is over.
#[must_use]
pub fn mission_line(m: &MissionResult) -> String {
    let struck: Vec<&Struck> = m.faults.iter().filter(|f| f.struck_ns.is_some()).collect();
    let mut kinds: Vec<(FaultKind, usize)> = Vec::new();
    for f in &struck {
        match kinds.iter_mut().find(|(k, _)| *k == f.fault.kind) {
            Some((_, n)) => *n += 1,
            None => kinds.push((f.fault.kind, 1)),
        }
    }
    kinds.sort();
    let kinds: Vec<String> = kinds.iter().map(|(k, n)| format!("{n} {k}")).collect();
    let missed = m.faults.len() - struck.len();
    let mut s = format!(
        "mission {}: {} after {:.0} s; {} faults ({}){}; {} restarts, {} failovers, {} retries; blind {:.1} s; {} recorded, {} lost{}",
        m.number,
        if m.succeeded {
            "succeeded"
        } else if m.cut_short {
            "cut short by the run's end"
        } else {
            "FAILED"
        },
        m.duration_s,
        struck.len(),
        if kinds.is_empty() {
            "none".to_owned()
        } else {
            kinds.join(", ")
        },
        if missed > 0 {
            format!(", {missed} not struck (the service did not run, or the mission was over)")
        } else {
            String::new()
        },
        m.broker.restarts,
        m.broker.failovers,
        m.broker.retries,
        m.broker.blind_ns as f64 / 1e9,
        m.recorded,
        m.lost,
        if m.leftovers > 0 {
            format!("; {} entries LEFT in shared memory", m.leftovers)
        } else {
            String::new()
        }
    );
    if m.failed() {
        let _ = write!(s, "\n  why: {}", m.reason);
        if !m.broker.help_for.is_empty() {
            let _ = write!(s, " (no provider left of {})", m.broker.help_for.join(", "));
        }
        if let Some(dir) = &m.kept {
            let _ = write!(s, "\n  kept: {}", dir.display());
        }
        if let Some(command) = &m.replay_command {
            let _ = write!(s, "\n  again: {command}");
            match (m.replay_fails_too, &m.replay_error) {
                (Some(true), _) => s.push_str("\n  the replay fails too"),
                (Some(false), _) => {
                    s.push_str("\n  the replay SUCCEEDS: the failure depends on live timing");
                }
                (None, Some(e)) => {
                    let _ = write!(s, "\n  the replay could not run: {e}");
                }
                (None, None) => {}
            }
        }
    }
    s
}

/// Runs missions until `options.duration` has passed; `on_mission` hears of each as soon
/// as it is over. `registry` checks the robot's kinds and builds the services of a
/// replay; `programs` the mission's programs, for a replay to live it again.
///
/// # Errors
/// When the robot, the script or the output folder cannot be used, or a mission cannot
/// start; a mission that fails is in the report.
pub fn run_chaos(
    options: &ChaosOptions,
    registry: &ServiceRegistry,
    programs: &dyn Programs,
    on_mission: &mut dyn FnMut(&MissionResult),
) -> Result<ChaosReport, DemoError> {
    for path in [&options.robot, &options.script] {
        if !path.exists() {
            return Err(DemoError::NotInRepository { path: path.clone() });
        }
    }
    std::fs::create_dir_all(&options.out).map_err(write_error(&options.out))?;
    let robot_text = std::fs::read_to_string(&options.robot)
        .map_err(|e| DemoError::Robot(format!("cannot read {}: {e}", options.robot.display())))?;
    let mission = load_mission(&options.script)?;

    let started = Instant::now();
    let end = started + options.duration;
    let sampler = SamplerThread::start(options.sample_every, started);
    let mut missions = Vec::new();
    let mut number = 0;
    while let Some(left) = end
        .checked_duration_since(Instant::now())
        .filter(|d| !d.is_zero())
    {
        number += 1;
        sampler.mission.store(number - 1, Ordering::Relaxed);
        let dir = options.out.join(format!("mission-{number:03}"));
        let result = run_mission(
            options,
            registry,
            programs,
            (&robot_text, &mission),
            number,
            (&dir, left),
            &sampler.active,
        );
        let result = match result {
            Ok(Some(result)) => result,
            // Interrupted (Ctrl-C): the run ends here.
            Ok(None) => break,
            Err(e) => {
                sampler.finish();
                return Err(e);
            }
        };
        on_mission(&result);
        missions.push(result);
        // After every mission: a run stopped by force keeps its report so far.
        let so_far = report_of(
            options.seed,
            started.elapsed().as_secs_f64(),
            missions.clone(),
            sampler.samples(),
        );
        write_report(&so_far, &options.out)?;
    }
    let samples = sampler.finish();
    let report = report_of(
        options.seed,
        started.elapsed().as_secs_f64(),
        missions,
        samples,
    );
    write_report(&report, &options.out)?;
    Ok(report)
}

/// `chaos.json` and `chaos.png` in `out`.
fn write_report(report: &ChaosReport, out: &Path) -> Result<(), DemoError> {
    let json =
        serde_json::to_string_pretty(report).map_err(|e| DemoError::Report(e.to_string()))?;
    let path = out.join("chaos.json");
    std::fs::write(&path, json + "\n").map_err(|source| DemoError::Write { path, source })?;
    picture::write_png(report, &out.join("chaos.png")).map_err(DemoError::Report)
}

/// One mission with its chaos; `None` when it was interrupted.
fn run_mission(
    options: &ChaosOptions,
    registry: &ServiceRegistry,
    programs: &dyn Programs,
    (robot_text, mission): (&str, &lewis_sequencer::Mission),
    number: u32,
    (dir, left): (&Path, Duration),
    sampling: &AtomicBool,
) -> Result<Option<MissionResult>, DemoError> {
    fresh_dir(dir)?;
    let device_seed = options.seed.wrapping_add(100 * u64::from(number));
    let robot_path = dir.join("robot.toml");
    let seeded = with_seed(robot_text, device_seed).map_err(DemoError::Robot)?;
    std::fs::write(&robot_path, seeded).map_err(write_error(&robot_path))?;
    let robot_path = std::path::absolute(&robot_path).map_err(write_error(&robot_path))?;
    let robot = load_robot(&robot_path, registry)?;
    let providers: Vec<String> = robot
        .services
        .iter()
        .filter(|s| !s.provides.is_empty())
        .map(|s| s.name.clone())
        .collect();
    let faults: Vec<ChaosFault> = ChaosPlan::over(providers).draw(options.seed, number);
    let faults_path = dir.join("faults.json");
    let text =
        serde_json::to_string_pretty(&faults).map_err(|e| DemoError::Report(e.to_string()))?;
    std::fs::write(&faults_path, text + "\n").map_err(write_error(&faults_path))?;

    let run = dir.join("run.mcap");
    let namespace = Namespace::unique("chaos");
    let _ = lewis_runtime::ipc::wipe_stale(&namespace);
    let striker = Striker::start(&namespace, faults).map_err(DemoError::Fault)?;
    // The run's end stops the mission running then.
    let launch_options = unattended_launch(
        (robot_path, &namespace, &options.lewis_exe),
        (&options.script, mission),
        (run.clone(), dir.join("events.jsonl")),
        left,
    );
    // The machine's use is read while the robot runs; a replay's afterwards is not the
    // run's.
    sampling.store(true, Ordering::Relaxed);
    let launched = Launch::new(robot, launch_options).and_then(Launch::run);
    sampling.store(false, Ordering::Relaxed);
    // The striker's node closes with it; then nothing of the run is alive and its
    // namespace can go.
    let log = striker.finish();
    let _ = lewis_runtime::ipc::wipe_ended(&namespace);
    let prefix = namespace.iceoryx2_prefix();
    let leftovers = entries_with_prefix(Path::new("/dev/shm"), &prefix)
        + entries_with_prefix(Path::new("/tmp/iceoryx2"), &prefix);
    let launched = launched?;
    if launched.up.ended_by == "signal" {
        return Ok(None);
    }
    let cut_short = launched.up.ended_by == "duration";
    let report = launched.mission.ok_or(DemoError::NoMission)?;
    let verdict = &report.verdict;
    let (recorded, lost) = match inspect(&run, &InfoOptions::default()) {
        Ok(info) => (info.message_count, info.lost_messages.values().sum()),
        Err(e) => {
            tracing::warn!("chaos: cannot read {}: {e}", run.display());
            (0, 0)
        }
    };
    let first = verdict.states_visited.first().map(|v| v.started_ns);
    let last = verdict
        .states_visited
        .last()
        .map(|v| v.ended_ns.unwrap_or(v.started_ns));
    let duration_s = match (first, last) {
        (Some(a), Some(b)) => (b - a) as f64 / 1e9,
        _ => 0.0,
    };
    let mut result = MissionResult {
        number,
        device_seed,
        succeeded: report.succeeded(),
        cut_short: cut_short && !report.succeeded(),
        reason: verdict.reason.clone(),
        states: verdict
            .states_visited
            .iter()
            .map(|v| v.state.clone())
            .collect(),
        duration_s,
        faults: log.faults,
        broker: log.broker,
        recorded,
        lost,
        leftovers,
        kept: None,
        replay_command: None,
        replay_fails_too: None,
        replay_error: None,
    };
    if !result.failed() {
        // Its line says it all; an hour of recordings would fill the disk.
        let _ = std::fs::remove_dir_all(dir);
    } else {
        result.kept = Some(dir.to_owned());
        let specs = replay_specs(&run, log.mission_start_ns, &result.faults);
        let mut command = format!("lewis replay {} --all", run.display());
        for spec in &specs {
            let _ = write!(command, " --inject-fault {spec}");
        }
        result.replay_command = Some(command);
        if options.reproduce {
            match live_again(registry, programs, &run, &specs) {
                Ok(fails) => result.replay_fails_too = Some(fails),
                Err(e) => result.replay_error = Some(e),
            }
        }
    }
    Ok(Some(result))
}

/// The harness's faults that struck, in `--inject-fault` words on the recording's clock.
fn replay_specs(run: &Path, mission_start_ns: Option<i64>, faults: &[Struck]) -> Vec<String> {
    let Some(start_ns) = mission_start_ns else {
        return Vec::new();
    };
    let Ok(files) = RecordingFiles::open(&[run.to_path_buf()]) else {
        return Vec::new();
    };
    let offset_ms = u64::try_from((start_ns - files.start_ns()) / 1_000_000).unwrap_or(0);
    faults
        .iter()
        .filter(|f| f.struck_ns.is_some())
        .filter_map(|f| f.fault.replay_spec(offset_ms))
        .collect()
}

/// Lives the recorded mission again with `specs` (closed loop); whether it fails.
fn live_again(
    registry: &ServiceRegistry,
    programs: &dyn Programs,
    run: &Path,
    specs: &[String],
) -> Result<bool, String> {
    let mut replay_options = ReplayOptions::new(vec![run.to_path_buf()]);
    replay_options.faults = specs
        .iter()
        .map(|s| s.parse::<FaultSpec>().map_err(|e| format!("{e}")))
        .collect::<Result<_, _>>()?;
    replay_options.services = ServiceSelection::All;
    replay_options.write_output = false;
    let report = replay_with(&replay_options, registry, Some(programs), &mut |_| {})
        .map_err(|e| format!("{e}"))?;
    let lived = report
        .mission
        .as_ref()
        .and_then(|m| m.replayed.as_ref())
        .ok_or_else(|| "the loop could not be closed".to_owned())?;
    Ok(!lived.succeeded)
}

/// The machine's use, read on a thread of its own every `every` while `active`.
struct SamplerThread {
    mission: Arc<AtomicU32>,
    active: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    samples: Arc<std::sync::Mutex<Vec<UseSample>>>,
    thread: std::thread::JoinHandle<()>,
}

impl SamplerThread {
    fn start(every: Duration, started: Instant) -> Self {
        let mission = Arc::new(AtomicU32::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let active = Arc::new(AtomicBool::new(false));
        let samples = Arc::new(std::sync::Mutex::new(Vec::new()));
        let (m, s, a) = (Arc::clone(&mission), Arc::clone(&stop), Arc::clone(&active));
        let kept = Arc::clone(&samples);
        let thread = std::thread::spawn(move || {
            let mut sampler = UseSampler::default();
            let mut next = Instant::now();
            while !s.load(Ordering::Relaxed) {
                if Instant::now() >= next {
                    if a.load(Ordering::Relaxed) {
                        let t_s = started.elapsed().as_secs_f64();
                        let sample = sampler.sample(t_s, m.load(Ordering::Relaxed));
                        if let Ok(mut kept) = kept.lock() {
                            kept.push(sample);
                        }
                    } else {
                        sampler.pause();
                    }
                    next += every;
                }
                // Short naps: the run's end is not kept waiting for a whole period.
                std::thread::sleep(Duration::from_millis(100).min(every));
            }
        });
        Self {
            mission,
            active,
            stop,
            samples,
            thread,
        }
    }

    /// The samples taken so far.
    fn samples(&self) -> Vec<UseSample> {
        self.samples.lock().map(|s| s.clone()).unwrap_or_default()
    }

    fn finish(self) -> Vec<UseSample> {
        self.stop.store(true, Ordering::Relaxed);
        let samples = self.samples;
        let _ = self.thread.join();
        samples.lock().map(|s| s.clone()).unwrap_or_default()
    }
}

/// The run's report from its missions and samples: the trends per mission.
fn report_of(
    seed: u64,
    ran_s: f64,
    missions: Vec<MissionResult>,
    samples: Vec<UseSample>,
) -> ChaosReport {
    let count = missions.len() as u32;
    // Per mission, the peak of each measure: missions are alike, so a peak that climbs
    // from one to the next is a leak, whatever each mission's own ups and downs.
    let peak = |f: &dyn Fn(&UseSample) -> Option<u64>| -> Vec<(f64, f64)> {
        (0..count)
            .filter_map(|m| {
                samples
                    .iter()
                    .filter(|s| s.mission == m)
                    .filter_map(f)
                    .max()
                    .map(|v| (f64::from(m), v as f64))
            })
            .collect()
    };
    let mut names: Vec<String> = samples
        .iter()
        .flat_map(|s| s.pss_kib.keys().cloned())
        .collect();
    names.sort();
    names.dedup();
    let memory = names
        .into_iter()
        .filter_map(|name| {
            let points = peak(&|s: &UseSample| s.pss_kib.get(&name).copied());
            Some(MemoryTrend {
                first_kib: points.first()?.1 as u64,
                last_kib: points.last()?.1 as u64,
                kib_per_mission: slope(&points),
                name,
            })
        })
        .collect();
    let cpu: Vec<f64> = samples.iter().filter_map(|s| s.cpu_percent).collect();
    let mean_cpu_percent = if cpu.is_empty() {
        0.0
    } else {
        cpu.iter().sum::<f64>() / cpu.len() as f64
    };
    ChaosReport {
        seed,
        ran_s,
        fds_per_mission: slope(&peak(&|s: &UseSample| Some(s.fds))),
        shm_entries_per_mission: slope(&peak(&|s: &UseSample| Some(s.shm_entries))),
        missions,
        samples,
        memory,
        mean_cpu_percent,
    }
}
