//! A mission's chaos: which provider fails when, how and for how long, drawn from a seed so
//! that a mission's faults can be given again (to a replay, or to a run with the same seed).

use lewis_replay::fault::FaultKind;
use lewis_service::Rng;
use serde::Serialize;

/// The kinds chaos strikes with: the live ones, a kill (SIGKILL once: the broker restarts
/// the process within its policy) and the harness's four.
pub const KINDS: [FaultKind; 5] = [
    FaultKind::Crash,
    FaultKind::Stall,
    FaultKind::OutOfService,
    FaultKind::Frozen,
    FaultKind::Garbage,
];

/// How the faults of a mission are drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct ChaosPlan {
    /// The providers that may be struck (the robot's services that provide an interface).
    pub providers: Vec<String>,
    /// No fault before this, in ms from the mission's start (the robot gets going first).
    pub first_ms: u64,
    /// No fault from this on, in ms from the mission's start (a mission ends before).
    pub last_ms: u64,
    /// The mean time between two faults, in ms (the gaps are exponential: faults come as
    /// they come, sometimes two at once).
    pub mean_gap_ms: u64,
    /// The shortest and the longest a stall, a freeze, garbage or an out-of-service last,
    /// in ms.
    pub lasting_ms: (u64, u64),
}

impl ChaosPlan {
    /// The default plan over `providers`: a fault every 15 s on average from 5 s to 150 s
    /// (the Challenge takes about two minutes), each lasting 1 to 6 s.
    #[must_use]
    pub fn over(providers: Vec<String>) -> Self {
        Self {
            providers,
            first_ms: 5_000,
            last_ms: 150_000,
            mean_gap_ms: 15_000,
            lasting_ms: (1_000, 6_000),
        }
    }

    /// The faults of mission `mission` of a chaos run seeded with `seed`, by time: the same
    /// for the same seed, mission and plan.
    #[must_use]
    pub fn draw(&self, seed: u64, mission: u32) -> Vec<ChaosFault> {
        let mut faults = Vec::new();
        if self.providers.is_empty() {
            return faults;
        }
        let mut rng = Rng::new(seed ^ Rng::seed_from_name(&format!("chaos mission {mission}")));
        let mut at_ms = self.first_ms as f64;
        loop {
            // Exponential gaps: a Poisson stream of faults.
            at_ms += -(self.mean_gap_ms as f64) * (1.0 - rng.next_f64()).ln();
            if at_ms >= self.last_ms as f64 {
                return faults;
            }
            let provider = self.providers[index(&mut rng, self.providers.len())].clone();
            let kind = KINDS[index(&mut rng, KINDS.len())];
            let (low, high) = self.lasting_ms;
            let for_ms = (kind != FaultKind::Crash)
                .then(|| rng.uniform(low as f64, high as f64).round() as u64);
            faults.push(ChaosFault {
                at_ms: at_ms.round() as u64,
                provider,
                kind,
                for_ms,
            });
        }
    }
}

/// An index below `len` (> 0).
fn index(rng: &mut Rng, len: usize) -> usize {
    // `len` is a handful of providers: the modulo's bias is nothing to speak of.
    (rng.next_u64() % len as u64) as usize
}

/// One fault of a mission's chaos.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ChaosFault {
    /// When it strikes, in ms from the mission's start.
    pub at_ms: u64,
    /// The service struck.
    pub provider: String,
    /// How.
    pub kind: FaultKind,
    /// How long it lasts before it is cleared (`None`: a kill, over at once).
    pub for_ms: Option<u64>,
}

impl ChaosFault {
    /// The fault in `lewis replay --inject-fault` words, its times from the recording's
    /// start given the mission's start at `mission_start_ms` from it. A kill has none: a
    /// closed-loop replay applies the live run's process deaths again by itself.
    #[must_use]
    pub fn replay_spec(&self, mission_start_ms: u64) -> Option<String> {
        let from = mission_start_ms + self.at_ms;
        self.for_ms.map(|for_ms| {
            format!(
                "{}@{from}ms-{}ms:{}",
                self.provider,
                from + for_ms,
                self.kind
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> ChaosPlan {
        ChaosPlan::over(vec!["laser".into(), "sonar".into(), "base".into()])
    }

    #[test]
    fn the_same_seed_and_mission_draw_the_same_faults_and_others_differ() {
        let plan = plan();
        assert_eq!(plan.draw(7, 3), plan.draw(7, 3));
        assert_ne!(plan.draw(7, 3), plan.draw(7, 4));
        assert_ne!(plan.draw(7, 3), plan.draw(8, 3));
    }

    #[test]
    fn faults_fall_in_the_window_in_order_and_last_as_planned() {
        let plan = plan();
        let mut count = 0;
        for mission in 0..50 {
            let faults = plan.draw(1, mission);
            count += faults.len();
            assert!(faults.windows(2).all(|w| w[0].at_ms <= w[1].at_ms));
            for f in &faults {
                assert!((plan.first_ms..plan.last_ms).contains(&f.at_ms), "{f:?}");
                assert!(plan.providers.contains(&f.provider));
                match f.kind {
                    FaultKind::Crash => assert_eq!(f.for_ms, None),
                    _ => assert!(f.for_ms.is_some_and(|ms| (1_000..=6_000).contains(&ms))),
                }
            }
        }
        // 145 s at one fault per 15 s: about 9.7 a mission.
        let mean = count as f64 / 50.0;
        assert!((7.0..12.5).contains(&mean), "{mean} faults a mission");
        // Every kind and every provider comes up.
        let all: Vec<ChaosFault> = (0..50).flat_map(|m| plan.draw(1, m)).collect();
        for kind in KINDS {
            assert!(all.iter().any(|f| f.kind == kind), "{kind} never drawn");
        }
    }

    #[test]
    fn no_provider_no_fault() {
        assert!(ChaosPlan::over(Vec::new()).draw(1, 0).is_empty());
    }

    #[test]
    fn a_lasting_fault_is_given_to_replay_with_its_window_and_a_kill_is_not() {
        let stall = ChaosFault {
            at_ms: 2_000,
            provider: "laser".into(),
            kind: FaultKind::Stall,
            for_ms: Some(1_500),
        };
        assert_eq!(
            stall.replay_spec(300).as_deref(),
            Some("laser@2300ms-3800ms:stall")
        );
        let kill = ChaosFault {
            kind: FaultKind::Crash,
            for_ms: None,
            ..stall
        };
        assert_eq!(kill.replay_spec(300), None);
        // The words parse as replay's faults.
        let spec: lewis_replay::fault::FaultSpec = "laser@2300ms-3800ms:stall".parse().unwrap();
        assert_eq!(spec.kind, FaultKind::Stall);
    }
}
