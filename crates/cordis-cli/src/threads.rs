//! `cordis render`'s threads when the user names none: every core, kept only while they step
//! faster than one thread.
//!
//! Two threads are not always faster. A network without locality (a random one) has each thread
//! read, every step, the positions the other wrote; on a host whose two vCPUs are far apart (a
//! cache line's trip at 200–260 ns on the Zen 3 of docs/BENCHMARKS-LOG.md, sixty-fourth session) a
//! 100,000-mass random network renders 0.6–0.8x as fast on two threads as on one. The output is
//! the same bits whatever the number of threads (the engine's promise, tested), so the render may
//! change it between blocks: [`AutoThreads`] times short chunks on both, keeps the faster, and
//! tries again after [`RETRY`] (a host may move its vCPUs), then after twice as long each time
//! a trial keeps the choice, up to [`RETRY_MOST`].
//!
//! The choice is kept apart from the clock: [`AutoThreads::next`] says what to step next and
//! [`AutoThreads::record`] takes how long it took, so the tests drive it with made-up times.

use std::time::Duration;

/// How long a trial chunk should take (its frames are set from the first chunk's time, and are
/// at most an eighth of the render, so that a short render ends its first trial too).
pub const TRIAL: Duration = Duration::from_millis(20);
/// A trial's chunks: on every thread (`true`) or on one, in the order every, one, one, every,
/// so that a steady drift of the machine's speed falls on both alike.
const ORDER: [bool; 4] = [true, false, false, true];
/// The threads are kept when they step at least this much faster than one thread (else one
/// thread is, which leaves the other cores free).
pub const GAIN: f64 = 1.05;
/// Time between trials, from the end of the last, when the last changed the choice.
pub const RETRY: Duration = Duration::from_secs(5);
/// The most time between trials (twice as long after each that keeps the choice).
pub const RETRY_MOST: Duration = Duration::from_secs(40);
/// The first chunk's frames, which sizes the trials.
const FIRST: usize = 64;

/// What to step next: on how many threads, and how many frames (`None`: as many as the caller
/// likes, a block; then call [`AutoThreads::record`] with the frames stepped and their time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    pub threads: usize,
    pub frames: Option<usize>,
}

#[derive(Clone, Copy, Debug)]
enum Phase {
    /// The first chunk, on every thread: its time sets the trials' frames.
    Sizing,
    /// Trial chunk `chunk` ([`ORDER`]).
    Trial { chunk: usize },
    /// The choice made, until the render's clock reaches `until`.
    Settled { threads: usize, until: Duration },
}

/// Chooses between `many` threads and one, as the render runs (see the module doc).
#[derive(Clone, Debug)]
pub struct AutoThreads {
    many: usize,
    phase: Phase,
    /// A chunk's most frames: an eighth of the render's (at least 1).
    most: usize,
    /// A trial chunk's frames.
    frames: usize,
    /// The current trial's seconds per frame summed, on every thread and on one.
    per_frame: [f64; 2],
    /// The last trial's speed of every thread against one (one's time over theirs), and its
    /// choice.
    ratio: Option<f64>,
    choice: Option<usize>,
    /// The time to the next trial.
    retry: Duration,
    trials: usize,
}

impl AutoThreads {
    /// For an engine set to `many` threads (at least 2) and a render of `frames` frames.
    pub fn new(many: usize, frames: usize) -> AutoThreads {
        let most = (frames / 8).max(1);
        AutoThreads {
            many: many.max(2),
            phase: Phase::Sizing,
            most,
            frames: FIRST.min(most),
            per_frame: [0.0; 2],
            ratio: None,
            choice: None,
            retry: RETRY,
            trials: 0,
        }
    }

    /// What to step next, at `now` on the render's clock.
    pub fn next(&mut self, now: Duration) -> Step {
        if let Phase::Settled { until, .. } = self.phase {
            if now >= until {
                self.phase = Phase::Trial { chunk: 0 };
                self.per_frame = [0.0; 2];
            }
        }
        match self.phase {
            Phase::Sizing => Step {
                threads: self.many,
                frames: Some(self.frames),
            },
            Phase::Trial { chunk } => Step {
                threads: if ORDER[chunk] { self.many } else { 1 },
                frames: Some(self.frames),
            },
            Phase::Settled { threads, .. } => Step {
                threads,
                frames: None,
            },
        }
    }

    /// The `frames` [`AutoThreads::next`] said (or fewer, at the render's end) took `took`; `now`
    /// is the render's clock after them.
    pub fn record(&mut self, frames: usize, took: Duration, now: Duration) {
        if frames == 0 {
            return;
        }
        let secs = took.as_secs_f64().max(1e-9);
        match self.phase {
            Phase::Sizing => {
                // (a chunk as long as `TRIAL` on these threads, at least one frame)
                let scaled = frames as f64 * TRIAL.as_secs_f64() / secs;
                self.frames = (scaled.clamp(1.0, 1e9) as usize).min(self.most);
                self.phase = Phase::Trial { chunk: 0 };
                self.per_frame = [0.0; 2];
            }
            Phase::Trial { chunk } => {
                self.per_frame[usize::from(!ORDER[chunk])] += secs / frames as f64;
                if chunk + 1 < ORDER.len() {
                    self.phase = Phase::Trial { chunk: chunk + 1 };
                } else {
                    let ratio = self.per_frame[1] / self.per_frame[0];
                    self.ratio = Some(ratio);
                    self.trials += 1;
                    let threads = if ratio >= GAIN { self.many } else { 1 };
                    self.retry = if self.choice == Some(threads) {
                        (2 * self.retry).min(RETRY_MOST)
                    } else {
                        RETRY
                    };
                    self.choice = Some(threads);
                    self.phase = Phase::Settled {
                        threads,
                        until: now + self.retry,
                    };
                }
            }
            Phase::Settled { .. } => {}
        }
    }

    /// What the trials found, for the render's last line: e.g. `1 thread (2 stepped 0.63x as
    /// fast as 1 in the last of 3 trials)`; `None` before the first trial has ended.
    pub fn summary(&self) -> Option<String> {
        let (ratio, threads) = (self.ratio?, self.choice?);
        let plural = |n: usize| if n == 1 { "" } else { "s" };
        let trials = match self.trials {
            1 => "1 trial".to_string(),
            n => format!("the last of {n} trials"),
        };
        Some(format!(
            "{threads} thread{} ({} stepped {ratio:.2}x as fast as 1 in {trials})",
            plural(threads),
            self.many,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps a render of `frames` frames through `auto`, each frame taking `per_frame(threads,
    /// now)` seconds; returns the frames stepped on each number of threads (index 1 and `many`).
    fn run(
        auto: &mut AutoThreads,
        frames: usize,
        block: usize,
        per_frame: impl Fn(usize, Duration) -> f64,
    ) -> Vec<(usize, usize)> {
        let mut now = Duration::ZERO;
        let mut done = 0;
        let mut steps = Vec::new();
        while done < frames {
            let s = auto.next(now);
            let n = s.frames.unwrap_or(block).min(frames - done);
            let took = Duration::from_secs_f64(n as f64 * per_frame(s.threads, now));
            now += took;
            auto.record(n, took, now);
            steps.push((s.threads, n));
            done += n;
        }
        steps
    }

    fn frames_on(steps: &[(usize, usize)], threads: usize) -> usize {
        steps.iter().filter(|s| s.0 == threads).map(|s| s.1).sum()
    }

    #[test]
    fn one_thread_is_kept_where_the_threads_are_slower() {
        let mut auto = AutoThreads::new(2, 2_000_000);
        // (1 µs a frame on one thread, 1.5 µs on two: a random network on far vCPUs)
        let steps = run(&mut auto, 2_000_000, 4096, |t, _| {
            if t == 1 {
                1e-6
            } else {
                1.5e-6
            }
        });
        assert_eq!(auto.choice, Some(1));
        // the sizing chunk, then a trial of chunks of 20 ms on two threads (13,333 frames),
        // whatever the block; about 2 s of work, so no second trial
        assert_eq!(steps[0], (2, FIRST));
        let trial: Vec<_> = steps[1..5].to_vec();
        assert_eq!(trial, [(2, 13_333), (1, 13_333), (1, 13_333), (2, 13_333)]);
        assert_eq!(steps[5], (1, 4096), "then blocks");
        let s = auto.summary().unwrap();
        assert!(
            s.starts_with("1 thread (2 stepped 0.67x as fast as 1 in 1 trial)"),
            "{s}"
        );
        let on_two = frames_on(&steps, 2);
        assert_eq!(on_two, FIRST + 2 * 13_333);
        assert_eq!(on_two + frames_on(&steps, 1), 2_000_000);
    }

    #[test]
    fn the_threads_are_kept_where_they_are_faster() {
        let mut auto = AutoThreads::new(2, 1_000_000);
        let steps = run(&mut auto, 1_000_000, 1 << 20, |t, _| {
            if t == 1 {
                1e-6
            } else {
                0.55e-6
            }
        });
        assert_eq!(auto.choice, Some(2));
        // the trial chunks are 20 ms long on two threads: 20 ms / 0.55 µs
        assert_eq!(steps[1], (2, 36_363));
        assert_eq!(steps[2], (1, 36_363));
        assert_eq!(steps[4], (2, 36_363));
        let s = auto.summary().unwrap();
        assert!(
            s.starts_with("2 threads (2 stepped 1.82x as fast as 1"),
            "{s}"
        );
        assert!(frames_on(&steps, 1) <= 2 * 36_363);
    }

    #[test]
    fn trials_that_keep_the_choice_come_twice_as_far_apart_up_to_the_most() {
        let mut auto = AutoThreads::new(2, usize::MAX);
        let (mut now, mut starts) = (Duration::ZERO, Vec::new());
        while now < Duration::from_secs(200) {
            let was = auto.trials;
            let s = auto.next(now);
            let n = s.frames.unwrap_or(4096);
            let took = Duration::from_secs_f64(n as f64 * if s.threads == 1 { 1e-6 } else { 2e-6 });
            if matches!(auto.phase, Phase::Trial { chunk: 0 }) {
                starts.push(now.as_secs_f64());
            }
            now += took;
            auto.record(n, took, now);
            assert!(auto.trials >= was);
        }
        // (a trial takes 60 ms: chunks of 20 ms on two threads, 10 ms on one)
        let gaps: Vec<f64> = starts.windows(2).map(|w| (w[1] - w[0]).round()).collect();
        assert_eq!(
            gaps,
            [5.0, 10.0, 20.0, 40.0, 40.0, 40.0, 40.0],
            "trials at {starts:?}"
        );
        assert_eq!(auto.choice, Some(1));
    }

    #[test]
    fn a_gain_below_the_threshold_keeps_one_thread() {
        let mut auto = AutoThreads::new(4, 1_000_000);
        run(&mut auto, 1_000_000, 4096, |t, _| {
            if t == 1 {
                1e-6
            } else {
                0.97e-6
            }
        });
        assert_eq!(auto.choice, Some(1));
    }

    #[test]
    fn a_later_trial_follows_the_machine_and_a_trial_cut_short_is_not_reported() {
        let mut auto = AutoThreads::new(2, 60_000_000);
        // two threads slower for the first 30 s of the render, then faster
        let slow_then_fast = |t: usize, now: Duration| match (t, now < Duration::from_secs(30)) {
            (1, _) => 1e-6,
            (_, true) => 1.5e-6,
            (_, false) => 0.6e-6,
        };
        let steps = run(&mut auto, 60_000_000, 4096, slow_then_fast);
        assert_eq!(auto.choice, Some(2));
        assert!(auto.trials >= 2, "{} trials", auto.trials);
        // the first trial chose one thread: most of the first 30 s ran on it
        assert!(
            frames_on(&steps, 1) > 25_000_000,
            "{}",
            frames_on(&steps, 1)
        );
        assert!(
            frames_on(&steps, 2) > 15_000_000,
            "{}",
            frames_on(&steps, 2)
        );
        let s = auto.summary().unwrap();
        assert!(
            s.starts_with("2 threads (2 stepped 1.67x as fast as 1 in the last of "),
            "{s}"
        );
        // a trial cut short by the render's end: the summary is the last ended one's
        let mut auto = AutoThreads::new(2, 1_000_000);
        run(
            &mut auto,
            1_000_000,
            4096,
            |t, _| if t == 1 { 1e-6 } else { 2e-6 },
        );
        let trials = auto.trials;
        let now = Duration::from_secs(100);
        assert_eq!(
            auto.next(now).threads,
            2,
            "a new trial starts on every thread"
        );
        auto.record(1000, Duration::from_millis(1), now);
        assert_eq!(auto.trials, trials);
        assert_eq!(auto.choice, Some(1));
        assert!(auto
            .summary()
            .unwrap()
            .starts_with("1 thread (2 stepped 0.50x"));
    }

    #[test]
    fn a_short_render_ends_its_first_trial_in_chunks_of_an_eighth() {
        let mut auto = AutoThreads::new(2, 100);
        let steps = run(
            &mut auto,
            100,
            4096,
            |t, _| if t == 1 { 1e-6 } else { 2e-6 },
        );
        assert_eq!(steps[..5], [(2, 12), (2, 12), (1, 12), (1, 12), (2, 12)]);
        assert_eq!(steps[5], (1, 40), "then the rest in a block");
        assert_eq!(auto.choice, Some(1));
        assert!(auto.summary().unwrap().contains("0.50x"));
        // a render of one frame: the sizing chunk alone, no choice, nothing to say
        let mut auto = AutoThreads::new(2, 1);
        assert_eq!(run(&mut auto, 1, 4096, |_, _| 1e-6), [(2, 1)]);
        assert_eq!((auto.choice, auto.summary()), (None, None));
        // a zero-frame record changes nothing
        let mut auto = AutoThreads::new(2, 1000);
        auto.record(0, Duration::from_millis(5), Duration::ZERO);
        let first = Step {
            threads: 2,
            frames: Some(FIRST),
        };
        assert_eq!(auto.next(Duration::ZERO), first);
    }
}
