//! `lewis bench closed-loop RUN.mcap`: how fast a whole mission is lived again (`lewis
//! replay --all`), side by side in one run:
//!
//! 1. **`lewis replay --all`**, whole (read, re-simulate the devices, the services, the
//!    broker's core, the sequencer and its programs, compare, write), as a multiple of the
//!    recording's real time, camera rendering and perception included.
//! 2. **The re-simulation** alone: the same replay without writing its output (what a
//!    sweep runs).
//! 3. **The same code called directly**: the time spent inside the services' and
//!    programs' own handlers during (2) (each one wrapped in a stopwatch), the floor any
//!    way of running them would cost. The ratio of (2) to it is the harness's overhead (the
//!    clock, the ordering, the broker's core, the bookkeeping, reading the recording).
//! 4. **Peak memory** of the process during the replays (its `VmHWM`).
//! 5. **A sweep** (`--sweep-fault`) of `steps` closed-loop replays on `jobs` threads.
//!
//! The wall clock is read here, in the stopwatches around handlers, never by the harness.

use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use lewis_service::{
    CommandError, Context, IncomingCommand, Input, Reply, ReplyEvent, Service, ServiceRegistry,
};
use serde::Serialize;

use crate::lockstep::{Program, Programs};
use crate::resim::{ReplayError, ReplayOptions, replay_with};
use crate::sweep::{SweepRunError, SweepSpec, sweep};
use lewis_recording::Recording;

/// What the closed-loop benchmark measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClosedLoopReport {
    /// The recording.
    pub recording: String,
    /// Its length, in seconds.
    pub duration_secs: f64,
    /// Whether the mission was lived again (else the figures are an open loop's).
    pub closed: bool,
    /// The replayed mission's time to finish, in seconds.
    pub mission_secs: Option<f64>,
    /// `lewis replay --all`, whole, in seconds.
    pub replay_secs: f64,
    /// The same without writing the output, in seconds.
    pub resimulation_secs: f64,
    /// The services' and programs' own handlers during that, in seconds.
    pub handlers_secs: f64,
    /// Handler calls timed.
    pub handler_calls: u64,
    /// The process's peak resident memory after the replay, in MiB.
    pub peak_rss_mib: f64,
    /// The sweep, if one was asked for: steps, jobs and seconds.
    pub sweep: Option<SweepTiming>,
}

/// A sweep's timing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SweepTiming {
    /// Replays.
    pub steps: u32,
    /// Threads.
    pub jobs: usize,
    /// Wall time, in seconds.
    pub secs: f64,
}

/// Why the benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum ClosedLoopError {
    /// The replay failed.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// The sweep failed.
    #[error(transparent)]
    Sweep(#[from] SweepRunError),
}

/// Measures (see the module documentation). `inner` builds the services; `options` is a
/// replay with `--all`; `sweep_spec` adds the sweep.
///
/// # Errors
/// When the recording cannot be replayed.
pub fn measure_closed(
    options: &ReplayOptions,
    inner: &Arc<ServiceRegistry>,
    programs: &(dyn Programs + Sync),
    sweep_spec: Option<&SweepSpec>,
) -> Result<ClosedLoopReport, ClosedLoopError> {
    let recording = Recording::open(&options.inputs).map_err(ReplayError::from)?;
    let duration_secs = (recording.end_ns() - recording.start_ns()) as f64 / 1e9;
    drop(recording);
    let started = Instant::now();
    replay_with(options, inner, Some(programs), &mut |_| {})?;
    let replay_secs = started.elapsed().as_secs_f64();
    let watch = Arc::new(Stopwatch::default());
    let timed_registry = timed(inner, &watch);
    let timed_programs = TimedPrograms {
        inner: programs,
        watch: watch.clone(),
    };
    let mut unwritten = options.clone();
    unwritten.write_output = false;
    let started = Instant::now();
    let report = replay_with(
        &unwritten,
        &timed_registry,
        Some(&timed_programs),
        &mut |_| {},
    )?;
    let resimulation_secs = started.elapsed().as_secs_f64();
    let peak_rss_mib = peak_rss_mib();
    let mission = report.mission.as_ref();
    let closed = mission.is_some_and(|m| m.loop_kind == crate::outcome::LoopKind::Closed);
    let mission_secs = mission
        .and_then(|m| m.replayed.as_ref())
        .and_then(|r| r.time_to_finish_ns)
        .map(|ns| ns as f64 / 1e9);
    let sweep = match sweep_spec {
        Some(spec) => {
            let started = Instant::now();
            sweep(options, inner, programs, spec, &|_| {})?;
            Some(SweepTiming {
                steps: spec.steps,
                jobs: spec.jobs,
                secs: started.elapsed().as_secs_f64(),
            })
        }
        None => None,
    };
    Ok(ClosedLoopReport {
        recording: options
            .inputs
            .first()
            .map(|p| p.display().to_string())
            .unwrap_or_default(),
        duration_secs,
        closed,
        mission_secs,
        replay_secs,
        resimulation_secs,
        handlers_secs: watch.nanos.load(Ordering::Relaxed) as f64 / 1e9,
        handler_calls: watch.calls.load(Ordering::Relaxed),
        peak_rss_mib,
        sweep,
    })
}

impl fmt::Display for ClosedLoopReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let lived = if self.closed {
            "lived again (closed loop)"
        } else {
            "NOT lived again (open loop)"
        };
        writeln!(
            f,
            "closed-loop replay of {} ({:.1} s recorded), {lived}",
            self.recording, self.duration_secs
        )?;
        let speed = |secs: f64| self.duration_secs / secs.max(f64::MIN_POSITIVE);
        writeln!(
            f,
            "  lewis replay --all, whole                        {:>8.2} s {:>7.1}x real time",
            self.replay_secs,
            speed(self.replay_secs)
        )?;
        writeln!(
            f,
            "  the same, no output written                      {:>8.2} s {:>7.1}x real time",
            self.resimulation_secs,
            speed(self.resimulation_secs)
        )?;
        writeln!(
            f,
            "  the services' and programs' handlers alone       {:>8.2} s {:>7.1}x real time ({} calls)",
            self.handlers_secs,
            speed(self.handlers_secs),
            self.handler_calls
        )?;
        writeln!(
            f,
            "  harness overhead over the handlers: {:.2}x; peak memory {:.1} MiB",
            self.resimulation_secs / self.handlers_secs.max(f64::MIN_POSITIVE),
            self.peak_rss_mib
        )?;
        if let Some(t) = self.mission_secs {
            writeln!(f, "  the mission lived again finished in {t:.1} s")?;
        }
        if let Some(s) = &self.sweep {
            writeln!(
                f,
                "  a sweep of {} replays on {} threads: {:.1} s ({:.1} s a replay)",
                s.steps,
                s.jobs,
                s.secs,
                s.secs * s.jobs as f64 / f64::from(s.steps.max(1))
            )?;
        }
        Ok(())
    }
}

/// The time spent in handlers, from every thread.
#[derive(Debug, Default)]
struct Stopwatch {
    nanos: AtomicU64,
    calls: AtomicU64,
}

impl Stopwatch {
    fn time<T>(&self, f: impl FnOnce() -> T) -> T {
        let started = Instant::now();
        let out = f();
        let spent = u64::try_from(started.elapsed().as_nanos()).unwrap_or(u64::MAX);
        self.nanos.fetch_add(spent, Ordering::Relaxed);
        self.calls.fetch_add(1, Ordering::Relaxed);
        out
    }
}

/// `inner`'s kinds, each service wrapped in the stopwatch.
fn timed(inner: &Arc<ServiceRegistry>, watch: &Arc<Stopwatch>) -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    for kind in inner.kinds() {
        let (inner, watch) = (inner.clone(), watch.clone());
        registry.register(kind, move |config| {
            let service = inner.build(config)?;
            Ok(Box::new(Timed {
                inner: service,
                watch: watch.clone(),
            }) as Box<dyn Service>)
        });
    }
    registry
}

struct TimedPrograms<'a> {
    inner: &'a (dyn Programs + Sync),
    watch: Arc<Stopwatch>,
}

impl Programs for TimedPrograms<'_> {
    fn build(&self, program: &std::path::Path, args: &[String]) -> Result<Program, String> {
        let built = self.inner.build(program, args)?;
        Ok(Program {
            service: Box::new(Timed {
                inner: built.service,
                watch: self.watch.clone(),
            }),
            ..built
        })
    }
}

/// A service whose handlers run under the stopwatch.
struct Timed {
    inner: Box<dyn Service>,
    watch: Arc<Stopwatch>,
}

impl Service for Timed {
    fn tick_period_ns(&self) -> Option<i64> {
        self.inner.tick_period_ns()
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        self.watch.time(|| self.inner.on_start(ctx))
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        self.watch.time(|| self.inner.on_input(ctx, input));
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        self.watch.time(|| self.inner.on_command(ctx, command))
    }

    fn on_reply(&mut self, ctx: &mut Context<'_>, reply: &ReplyEvent<'_>) {
        self.watch.time(|| self.inner.on_reply(ctx, reply));
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        self.watch.time(|| self.inner.on_tick(ctx));
    }

    fn on_stop(&mut self, ctx: &mut Context<'_>) {
        self.watch.time(|| self.inner.on_stop(ctx));
    }

    fn exit_code(&self) -> Option<i32> {
        self.inner.exit_code()
    }
}

/// The process's peak resident set (`VmHWM` of `/proc/self/status`: Linux, where the
/// benchmark runs), in MiB; 0 when it cannot be read.
fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|status| {
            status
                .lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}
