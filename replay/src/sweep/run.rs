//! Running a sweep: one closed-loop replay per fault time, on worker threads, each turned
//! into a [`SweepPoint`].

use lewis_service::ServiceRegistry;

use super::{FailedPoint, Sweep, SweepPoint, fault_times, run_jobs};
use crate::fault::{FaultKind, FaultSpec, format_seconds};
use crate::lockstep::{AnswerSource, Programs};
use crate::outcome::{LoopKind, MissionOutcome};
use crate::resim::{ReplayError, ReplayOptions, prepare, replay_with};
use lewis_recording::Recording;

/// What to sweep: which providers fail together, how, at how many times, on how many
/// threads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SweepSpec {
    /// The providers that fail together at each time.
    pub providers: Vec<String>,
    /// How they fail.
    pub kind: FaultKind,
    /// How many times across the run.
    pub steps: u32,
    /// Replays run at once.
    pub jobs: usize,
}

/// Why a sweep cannot run.
#[derive(Debug, thiserror::Error)]
pub enum SweepRunError {
    /// The recording, an option or the first set-up failed.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// The recording cannot be lived again, so no time can be judged.
    #[error("a sweep lives the mission again, and this recording cannot be: {0}")]
    OpenLoop(String),
    /// No mission was recorded: there is nothing to judge.
    #[error("the recording holds no mission (no /lewis/sequencer records): nothing to judge")]
    NoMission,
    /// `--steps` or the run's length leave no time to fail at.
    #[error("no fault time: the run is empty or --steps is 0")]
    NoTimes,
}

/// Sweeps `spec`'s fault across the run of `options` (whose `services` must be `All`):
/// each replay is `options` with the sweep's fault added and no output file. `done` is
/// called with the number of replays finished, from the worker threads.
///
/// # Errors
/// When the recording cannot be read or lived again; a replay that fails at one time is
/// a [`FailedPoint`] of the sweep.
pub fn sweep(
    options: &ReplayOptions,
    registry: &ServiceRegistry,
    programs: &(dyn Programs + Sync),
    spec: &SweepSpec,
    done: &(dyn Fn(usize) + Sync),
) -> Result<Sweep, SweepRunError> {
    let recording = Recording::open(&options.inputs).map_err(ReplayError::from)?;
    let prepared = prepare(&recording, options, registry, Some(programs))?;
    if let LoopKind::Open { because: Some(why) } = prepared.closure.loop_kind() {
        return Err(SweepRunError::OpenLoop(why));
    }
    if prepared.closure.mission.is_none() {
        return Err(SweepRunError::NoMission);
    }
    let (start_ns, end_ns) = (recording.start_ns(), recording.end_ns());
    let recorded = MissionOutcome::of(&prepared.closure.recorded, start_ns, None, None);
    drop(recording);
    let times = fault_times(0, end_ns - start_ns, spec.steps);
    if times.is_empty() {
        return Err(SweepRunError::NoTimes);
    }
    let finished = std::sync::atomic::AtomicUsize::new(0);
    let results = run_jobs(&times, spec.jobs, |_, at_ns| {
        let point = sweep_point(options, registry, programs, spec, at_ns);
        let count = finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        done(count);
        point
    });
    let mut points = Vec::new();
    let mut failed_points = Vec::new();
    for (result, &fault_at_ns) in results.into_iter().zip(&times) {
        match result {
            Ok(point) => points.push(point),
            Err(error) => failed_points.push(FailedPoint { fault_at_ns, error }),
        }
    }
    Ok(Sweep {
        recording: options
            .inputs
            .first()
            .map(|p| p.display().to_string())
            .unwrap_or_default(),
        providers: spec.providers.clone(),
        kind: spec.kind,
        steps: spec.steps,
        duration_ns: end_ns - start_ns,
        recorded_succeeded: Some(recorded.succeeded),
        recorded_time_to_finish_ns: recorded.time_to_finish_ns,
        points,
        failed_points,
    })
}

/// The replay of `options` (whose `services` must be `All`) with `spec`'s fault at `at_ns`
/// (from the start of the recording), as a point: one job of a sweep, which `lewis test`
/// also runs on its own. `spec`'s `steps` and `jobs` do not matter here. No output file is
/// written.
///
/// # Errors
/// Why the replay could not run, or said nothing of the mission, for people.
pub fn sweep_point(
    options: &ReplayOptions,
    registry: &ServiceRegistry,
    programs: &(dyn Programs + Sync),
    spec: &SweepSpec,
    at_ns: i64,
) -> Result<SweepPoint, String> {
    let mut options = options.clone();
    options.write_output = false;
    for provider in &spec.providers {
        let text = format!("{provider}@{}:{}", format_seconds(at_ns), spec.kind);
        let fault: FaultSpec = text.parse().map_err(|e| format!("{text}: {e}"))?;
        options.faults.push(fault);
    }
    let report =
        replay_with(&options, registry, Some(programs), &mut |_| {}).map_err(|e| e.to_string())?;
    let mission = report
        .mission
        .ok_or_else(|| "the replay says nothing of the mission".to_owned())?;
    let replayed = mission
        .replayed
        .ok_or_else(|| "the mission was not lived again".to_owned())?;
    let state_at_fault = replayed
        .states
        .iter()
        .rev()
        .find(|v| v.started_ns <= at_ns)
        .map(|v| v.state.clone());
    Ok(SweepPoint {
        fault_at_ns: at_ns,
        succeeded: replayed.succeeded,
        time_to_finish_ns: replayed.time_to_finish_ns,
        longest_blind_ns: replayed.longest_blind.as_ref().map(|g| g.gap_ns),
        longest_blind: replayed
            .longest_blind
            .as_ref()
            .map(|g| format!("{} had no {}", g.client, g.interface)),
        state_at_fault,
        reason: replayed.reason,
        answer_sources: mission
            .answers
            .iter()
            .map(|a| {
                match a.source {
                    AnswerSource::Recorded => "recorded",
                    AnswerSource::Suggested => "suggested",
                    AnswerSource::Stop => "stop",
                }
                .to_owned()
            })
            .collect(),
    })
}
