//! The sweep's replays on worker threads.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::thread;

/// Runs `one(index, time)` for every time of `times` on `jobs` worker threads and returns
/// the results in the order of `times`, whatever the number of jobs and however long each
/// takes: `--jobs 2` gives the same output as `--jobs 1` as long as `one` depends only on
/// its arguments.
///
/// `jobs` is clamped to `1..=times.len()`; no thread is started for an empty `times`.
/// Each worker takes the next time not yet taken, so a slow replay does not hold up the
/// others. A panic in `one` is carried to the caller once every worker has stopped.
pub fn run_jobs<T: Send, E: Send>(
    times: &[i64],
    jobs: usize,
    one: impl Fn(usize, i64) -> Result<T, E> + Sync,
) -> Vec<Result<T, E>> {
    if times.is_empty() {
        return Vec::new();
    }
    let jobs = jobs.clamp(1, times.len());
    let next = AtomicUsize::new(0);
    let worker = || {
        let mut done = Vec::new();
        loop {
            // Relaxed: the counter only hands out indices; the results travel through
            // the join, which orders everything.
            let index = next.fetch_add(1, Ordering::Relaxed);
            let Some(&time) = times.get(index) else {
                return done;
            };
            done.push((index, one(index, time)));
        }
    };
    let mut done: Vec<(usize, Result<T, E>)> = thread::scope(|scope| {
        let workers: Vec<_> = (0..jobs).map(|_| scope.spawn(worker)).collect();
        let mut done = Vec::with_capacity(times.len());
        for handle in workers {
            match handle.join() {
                Ok(part) => done.extend(part),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        done
    });
    done.sort_unstable_by_key(|(index, _)| *index);
    done.into_iter().map(|(_, result)| result).collect()
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;
    use std::time::Duration;

    use super::*;

    /// A replay whose length varies with its time (the later ones finish first with
    /// several jobs), and which fails at every third time.
    fn uneven(index: usize, time: i64) -> Result<String, String> {
        let millis = u64::try_from(12 - time.rem_euclid(13)).unwrap_or(0);
        thread::sleep(Duration::from_millis(millis * 2));
        if index % 3 == 2 {
            Err(format!("no replay at {time}"))
        } else {
            Ok(format!("{index}: {time}"))
        }
    }

    #[test]
    fn results_are_in_the_order_of_the_times_whatever_the_jobs() {
        let times: Vec<i64> = (0..13).collect();
        let alone = run_jobs(&times, 1, uneven);
        assert_eq!(alone.len(), 13);
        assert_eq!(alone[0], Ok("0: 0".to_owned()));
        assert_eq!(alone[2], Err("no replay at 2".to_owned()));
        for jobs in [0, 2, 3, 13, 100] {
            assert_eq!(run_jobs(&times, jobs, uneven), alone, "{jobs} jobs");
        }
    }

    #[test]
    fn every_time_is_run_once_on_at_most_jobs_threads() {
        let times: Vec<i64> = (100..120).collect();
        let seen = Mutex::new(Vec::new());
        let results = run_jobs(&times, 3, |index, time| {
            thread::sleep(Duration::from_millis(1));
            if let Ok(mut seen) = seen.lock() {
                seen.push((index, time, thread::current().id()));
            }
            Ok::<_, ()>(time)
        });
        assert_eq!(results, times.iter().map(|&t| Ok(t)).collect::<Vec<_>>());
        let mut seen = seen.into_inner().unwrap_or_default();
        seen.sort_by_key(|&(index, _, _)| index);
        let indices: Vec<(usize, i64)> = seen.iter().map(|&(i, t, _)| (i, t)).collect();
        assert_eq!(indices, (0..20).zip(100..120).collect::<Vec<_>>());
        let mut threads: Vec<_> = seen.iter().map(|&(_, _, id)| id).collect();
        threads.sort_by_key(|id| format!("{id:?}"));
        threads.dedup();
        assert!(threads.len() <= 3, "{} threads", threads.len());
    }

    #[test]
    fn no_times_start_no_thread() {
        let results = run_jobs(&[], 4, |_, _| -> Result<(), ()> {
            panic!("nothing to run")
        });
        assert!(results.is_empty());
    }
}
