//! Lock-step worker threads for [`crate::Engine::process`]: a spin barrier, a small persistent
//! pool, and a raw view of the engine's state buffers that the threads share phase by phase.
//!
//! How the engine uses them (see `engine.rs`, `Job`): every step is two phases separated by a
//! barrier. In each phase every shared buffer is either read by everyone and written by no one, or
//! cut into disjoint ranges each written (and read) by one thread only. The barrier orders the
//! phases (its atomics give the happens-before edges), so no two threads ever access the same
//! element with at least one write without a barrier between them: there is no data race.
//!
//! The pool is created once (by [`crate::Engine::set_threads`], or on the first threaded
//! `process` of a clone) and kept in the engine, so that `process` itself does not allocate: it
//! only publishes a job, wakes the workers, runs thread 0's share itself, and waits until every
//! worker has finished with the job before it returns (or unwinds).

use std::ops::Range;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

/// How long a barrier wait spins (with the CPU's pause hint) before it sleeps. A phase of a large
/// network lasts tens to hundreds of microseconds and the threads finish it close together, so
/// spinning catches the others without a system call; it also outlasts a futex wake-up (a few
/// microseconds), so a thread that slept does not make the next wait sleep in turn. Beyond it,
/// the thread waited for has most likely been preempted by another process, and spinning longer
/// would only take the core from it (measured: a 2 ms spin made 2 threads 30 times slower than
/// one when a third process was busy; 50 µs, 2 times).
const BARRIER_SPIN: Duration = Duration::from_micros(50);
/// How long an idle worker spins before it parks, so that back-to-back blocks wake it cheaply.
const IDLE_SPIN: Duration = Duration::from_micros(200);

/// Spins until `done()` or `give_up()` (then false), for at most `spin`; false if time ran out.
#[inline]
fn spin_until(spin: Duration, done: impl Fn() -> bool, give_up: impl Fn() -> bool) -> bool {
    let mut start: Option<Instant> = None;
    let mut i = 0u32;
    while !done() {
        if give_up() {
            return false;
        }
        i = i.wrapping_add(1);
        if i.is_multiple_of(64) && start.get_or_insert_with(Instant::now).elapsed() >= spin {
            return false;
        }
        std::hint::spin_loop();
    }
    true
}

/// A worker panicked (or the thread that waits was told to give up): the job must stop.
#[derive(Debug)]
pub(crate) struct Poisoned;

/// A reusable barrier for a fixed number of threads: it spins for a while, then sleeps on a
/// condition variable. Neither allocates.
///
/// Ordering: every thread's `fetch_add` on `count` is a release (and acquire) in one release
/// sequence; the last thread to arrive acquires all of them, then publishes a new generation
/// that every waiter acquires (by its atomic load, or through the mutex it sleeps under). So
/// everything any thread did before `wait` happens-before everything every thread does after it.
///
/// No lost wake-up: a sleeper increments `sleepers` and then re-reads `generation` under the mutex;
/// the last arriver stores `generation` and then reads `sleepers`, all four `SeqCst`, so at least
/// one of them sees the other's write. If the sleeper sees the new generation it does not sleep;
/// if the arriver sees the sleeper, it notifies under the mutex, which the sleeper holds from its
/// check until `Condvar::wait` releases it, so the notification cannot fall between the two.
#[derive(Debug)]
pub(crate) struct SpinBarrier {
    n: usize,
    spin: Duration,
    count: AtomicUsize,
    generation: AtomicUsize,
    poisoned: AtomicBool,
    sleepers: AtomicUsize,
    lock: Mutex<()>,
    wake: Condvar,
}

impl SpinBarrier {
    /// A barrier for `n` threads that spins for `spin` before sleeping.
    pub(crate) fn new(n: usize, spin: Duration) -> SpinBarrier {
        SpinBarrier {
            n,
            spin,
            count: AtomicUsize::new(0),
            generation: AtomicUsize::new(0),
            poisoned: AtomicBool::new(false),
            sleepers: AtomicUsize::new(0),
            lock: Mutex::new(()),
            wake: Condvar::new(),
        }
    }

    /// Waits until all `n` threads have called `wait`; `Err` if the barrier is poisoned.
    pub(crate) fn wait(&self) -> Result<(), Poisoned> {
        let generation = self.generation.load(Ordering::Acquire);
        if self.count.fetch_add(1, Ordering::AcqRel) + 1 == self.n {
            // Last to arrive: reset the count for the next use, then release everyone. A waiter
            // that sees the new generation also sees the reset.
            self.count.store(0, Ordering::Relaxed);
            self.generation
                .store(generation.wrapping_add(1), Ordering::SeqCst);
            if self.sleepers.load(Ordering::SeqCst) > 0 {
                let _guard = self.lock.lock().unwrap_or_else(PoisonError::into_inner);
                self.wake.notify_all();
            }
        } else {
            let passed = || self.generation.load(Ordering::Acquire) != generation;
            let poisoned = || self.poisoned.load(Ordering::Relaxed);
            if !spin_until(self.spin, passed, poisoned) && !poisoned() {
                let mut guard = self.lock.lock().unwrap_or_else(PoisonError::into_inner);
                self.sleepers.fetch_add(1, Ordering::SeqCst);
                while self.generation.load(Ordering::SeqCst) == generation && !poisoned() {
                    guard = self
                        .wake
                        .wait(guard)
                        .unwrap_or_else(PoisonError::into_inner);
                }
                self.sleepers.fetch_sub(1, Ordering::SeqCst);
            }
        }
        if self.poisoned.load(Ordering::Acquire) {
            return Err(Poisoned);
        }
        Ok(())
    }

    /// Makes every present and future `wait` fail, so that no thread waits for a dead one.
    pub(crate) fn poison(&self) {
        self.poisoned.store(true, Ordering::SeqCst);
        let _guard = self.lock.lock().unwrap_or_else(PoisonError::into_inner);
        self.wake.notify_all();
    }

    pub(crate) fn is_poisoned(&self) -> bool {
        self.poisoned.load(Ordering::Acquire)
    }
}

/// A buffer of `f64` shared by the threads of one job, addressed by index ranges.
///
/// It is a raw pointer and a length taken from a `&mut [f64]` that the job's creator holds for
/// the whole job (so the memory is valid and nothing else touches it meanwhile). The two accessors
/// are `unsafe`: the caller promises the phase discipline described in the module documentation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SharedBuf {
    ptr: *mut f64,
    len: usize,
}

// SAFETY: a `SharedBuf` is only a pointer and a length; sending or sharing it is harmless. Every
// access through it goes through `read` / `write`, whose callers uphold the phase discipline that
// excludes data races (see the module documentation and `Job::run` in `engine.rs`).
unsafe impl Send for SharedBuf {}
// SAFETY: as for `Send`.
unsafe impl Sync for SharedBuf {}

impl SharedBuf {
    /// Borrows `v` for the job; the caller must keep `v` mutably borrowed (and untouched) for as
    /// long as any thread may use the returned value.
    pub(crate) fn new(v: &mut [f64]) -> SharedBuf {
        SharedBuf {
            ptr: v.as_mut_ptr(),
            len: v.len(),
        }
    }

    /// The whole buffer, read-only.
    ///
    /// # Safety
    /// The buffer must still be valid (the job's creator still holds it), and no thread may write
    /// any element of it while the returned slice is alive.
    pub(crate) unsafe fn read(&self) -> &[f64] {
        // SAFETY: `ptr`/`len` come from a live `&mut [f64]` (see `new`); the caller guarantees
        // that no one writes the buffer while this shared slice lives.
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }

    /// Elements `r`, read-only.
    ///
    /// # Safety
    /// The buffer must still be valid, and no thread may write any element of `r` while the
    /// returned slice is alive.
    pub(crate) unsafe fn read_part(&self, r: Range<usize>) -> &[f64] {
        assert!(r.start <= r.end && r.end <= self.len, "range out of buffer");
        // SAFETY: in bounds (just checked); the caller guarantees that no one writes `r` while
        // this shared slice lives.
        unsafe { std::slice::from_raw_parts(self.ptr.add(r.start), r.end - r.start) }
    }

    /// Elements `r`, exclusively.
    ///
    /// # Safety
    /// The buffer must still be valid, and no other thread may read or write any element of `r`
    /// (nor hold a slice that covers it) while the returned slice is alive.
    #[allow(clippy::mut_from_ref)] // exclusivity is the caller's promise, per range
    pub(crate) unsafe fn write(&self, r: Range<usize>) -> &mut [f64] {
        assert!(r.start <= r.end && r.end <= self.len, "range out of buffer");
        // SAFETY: in bounds (just checked); the caller guarantees exclusive access to `r`.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(r.start), r.end - r.start) }
    }
}

/// Work the pool's threads run together: thread `t` of `threads` runs `run(t, barrier)`.
pub(crate) trait Task: Sync {
    /// Thread `t`'s share (t >= 1: the workers; the caller runs thread 0 itself).
    fn run(&self, t: usize, barrier: &SpinBarrier) -> Result<(), Poisoned>;
}

/// A published job: a pointer to the caller's `Task` value and the function that runs it.
#[derive(Clone, Copy)]
struct Published {
    data: *const (),
    call: unsafe fn(*const (), usize, &SpinBarrier) -> Result<(), Poisoned>,
}

// SAFETY: `data` points to a `Task`, which is `Sync`; `Pool::run` keeps it alive until every worker
// has finished with it (see there).
unsafe impl Send for Published {}

/// Runs `data` as a `T`.
///
/// # Safety
/// `data` must point to a live `T`.
unsafe fn call<T: Task>(data: *const (), t: usize, b: &SpinBarrier) -> Result<(), Poisoned> {
    // SAFETY: the caller guarantees `data` is a live `T`; `T: Sync`, so sharing it is fine.
    let task = unsafe { &*data.cast::<T>() };
    task.run(t, b)
}

#[derive(Debug)]
struct Shared {
    job: Mutex<Option<PublishedDebug>>,
    epoch: AtomicU64,
    done: AtomicUsize,
    quit: AtomicBool,
    barrier: SpinBarrier,
}

/// `Published` with a `Debug` that prints nothing secret-looking (only the fact).
struct PublishedDebug(Published);

impl std::fmt::Debug for PublishedDebug {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("job")
    }
}

/// `threads - 1` parked worker threads plus the calling thread, run in lock-step on one job at a
/// time. Dropping the pool stops and joins the workers.
#[derive(Debug)]
pub(crate) struct Pool {
    shared: Arc<Shared>,
    workers: Vec<JoinHandle<()>>,
}

impl Pool {
    /// Starts `threads - 1` workers (allocates: call it outside the audio path).
    pub(crate) fn new(threads: usize) -> Pool {
        let threads = threads.max(1);
        // With more threads than cores, a spinning waiter only delays the thread it waits for.
        let cores = thread::available_parallelism().map_or(1, |n| n.get());
        let spin = if threads <= cores {
            BARRIER_SPIN
        } else {
            Duration::ZERO
        };
        let shared = Arc::new(Shared {
            job: Mutex::new(None),
            epoch: AtomicU64::new(0),
            done: AtomicUsize::new(0),
            quit: AtomicBool::new(false),
            barrier: SpinBarrier::new(threads, spin),
        });
        let mut workers = Vec::with_capacity(threads - 1);
        for t in 1..threads {
            let worker_shared = Arc::clone(&shared);
            match thread::Builder::new()
                .name(format!("cordis-engine-{t}"))
                .spawn(move || worker(&worker_shared, t))
            {
                Ok(w) => workers.push(w),
                Err(e) => {
                    // release the workers already started (they wait at the barrier), then stop
                    shared.barrier.poison();
                    drop(Pool { shared, workers });
                    panic!("cannot start an engine worker thread: {e}");
                }
            }
        }
        // Wait until every worker runs its loop, so that what starting a thread allocates is done
        // when this returns (`process` must not allocate).
        let _ = shared.barrier.wait();
        Pool { shared, workers }
    }

    /// Number of threads, the caller's included.
    pub(crate) fn threads(&self) -> usize {
        self.workers.len() + 1
    }

    /// True once a worker has panicked: the pool must not be used again.
    pub(crate) fn is_poisoned(&self) -> bool {
        self.shared.barrier.is_poisoned()
    }

    /// Runs `task` on every thread: workers run `task.run(t, ..)` for `t >= 1` while the caller
    /// runs `main(barrier)` (thread 0's share). Returns once every worker has finished with
    /// `task`, also when `main` unwinds. Does not allocate.
    pub(crate) fn run<T: Task, R>(&self, task: &T, main: impl FnOnce(&SpinBarrier) -> R) -> R {
        let shared = &*self.shared;
        *shared.job.lock().unwrap_or_else(PoisonError::into_inner) =
            Some(PublishedDebug(Published {
                data: (task as *const T).cast(),
                call: call::<T>,
            }));
        shared.done.store(0, Ordering::Relaxed);
        // Release: a worker that sees the new epoch also sees the job and `done == 0`.
        shared.epoch.fetch_add(1, Ordering::Release);
        for w in &self.workers {
            w.thread().unpark();
        }
        // `task` (borrowed for this call) must outlive every worker's use of it: this guard waits
        // for all of them, also if `main` panics (it then poisons the barrier first, so that no
        // worker waits forever for thread 0).
        let _wait = WaitForWorkers {
            shared,
            workers: self.workers.len(),
        };
        main(&shared.barrier)
    }

    /// [`Pool::run`] for a step's job: `Err(Poisoned)` if thread 0's share failed or a worker
    /// panicked.
    pub(crate) fn run_steps<T: Task>(
        &self,
        task: &T,
        main: impl FnOnce(&SpinBarrier) -> Result<(), Poisoned>,
    ) -> Result<(), Poisoned> {
        self.run(task, main)?;
        if self.is_poisoned() {
            Err(Poisoned)
        } else {
            Ok(())
        }
    }
}

struct WaitForWorkers<'a> {
    shared: &'a Shared,
    workers: usize,
}

impl Drop for WaitForWorkers<'_> {
    fn drop(&mut self) {
        if thread::panicking() {
            self.shared.barrier.poison();
        }
        // Acquire: pairs with each worker's release increment, so their writes are visible.
        let done = || self.shared.done.load(Ordering::Acquire) >= self.workers;
        if !spin_until(BARRIER_SPIN, done, || false) {
            while !done() {
                thread::yield_now();
            }
        }
        *self
            .shared
            .job
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = None;
    }
}

impl Drop for Pool {
    fn drop(&mut self) {
        self.shared.quit.store(true, Ordering::Release);
        for w in &self.workers {
            w.thread().unpark();
        }
        for w in self.workers.drain(..) {
            let _ = w.join(); // a worker never panics out of its loop (see `worker`)
        }
    }
}

fn worker(shared: &Shared, t: usize) {
    let _ = shared.barrier.wait(); // started (see `Pool::new`)
    let mut seen = 0u64;
    loop {
        // Wait for a new job: spin a little, then park. `unpark` before `park` leaves a token, so
        // a wake-up is never lost; a spurious return just loops.
        let start = Instant::now();
        let mut i = 0u32;
        loop {
            if shared.quit.load(Ordering::Acquire) {
                return;
            }
            if shared.epoch.load(Ordering::Acquire) != seen {
                break;
            }
            i = i.wrapping_add(1);
            if !i.is_multiple_of(64) || start.elapsed() < IDLE_SPIN {
                std::hint::spin_loop();
            } else {
                thread::park();
            }
        }
        seen = shared.epoch.load(Ordering::Acquire);
        let job = shared
            .job
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .as_ref()
            .map(|p| p.0);
        if let Some(job) = job {
            // SAFETY: `Pool::run` published `job.data` as a live task of the type `job.call`
            // expects, and does not return (nor unwind past `WaitForWorkers`) before this worker
            // increments `done` below, so the task outlives this call.
            let r = catch_unwind(AssertUnwindSafe(|| unsafe {
                (job.call)(job.data, t, &shared.barrier)
            }));
            if r.is_err() {
                shared.barrier.poison();
            }
        }
        shared.done.fetch_add(1, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each thread writes its own element of a shared buffer, then (after a barrier) reads all of
    /// them: the pattern `Job` uses. Every read sees the value of the current round.
    struct Rounds {
        buf: SharedBuf,
        rounds: usize,
        panic_on: Option<usize>,
    }

    impl Task for Rounds {
        fn run(&self, t: usize, barrier: &SpinBarrier) -> Result<(), Poisoned> {
            if self.panic_on == Some(t) {
                panic!("worker {t} fails on purpose");
            }
            for round in 0..self.rounds {
                // SAFETY: element `t` is this thread's alone in this phase.
                unsafe { self.buf.write(t..t + 1)[0] = (round * 10 + t) as f64 };
                barrier.wait()?;
                // SAFETY: nobody writes in this phase.
                let all = unsafe { self.buf.read() };
                for (u, &v) in all.iter().enumerate() {
                    assert_eq!(v, (round * 10 + u) as f64, "thread {t} reads {u}");
                }
                barrier.wait()?;
            }
            Ok(())
        }
    }

    #[test]
    fn the_pool_runs_lock_step_phases_many_times() {
        for threads in [1, 2, 3, 4] {
            let pool = Pool::new(threads);
            assert_eq!(pool.threads(), threads);
            let mut v = vec![0.0; threads];
            for _ in 0..20 {
                let task = Rounds {
                    buf: SharedBuf::new(&mut v),
                    rounds: 50,
                    panic_on: None,
                };
                let r = pool.run(&task, |b| task.run(0, b));
                assert!(r.is_ok());
                assert!(!pool.is_poisoned());
            }
            assert_eq!(v[threads - 1], (49 * 10 + threads - 1) as f64);
        }
    }

    #[test]
    fn a_worker_panic_poisons_the_barrier_instead_of_hanging() {
        let pool = Pool::new(3);
        let mut v = vec![0.0; 3];
        let task = Rounds {
            buf: SharedBuf::new(&mut v),
            rounds: 10,
            panic_on: Some(2),
        };
        let r = pool.run(&task, |b| task.run(0, b));
        assert!(r.is_err());
        assert!(pool.is_poisoned());
        drop(pool); // joins the workers: they survived the panic
    }

    #[test]
    fn a_panic_on_the_calling_thread_waits_for_the_workers() {
        let pool = Pool::new(2);
        let mut v = vec![0.0; 2];
        let task = Rounds {
            buf: SharedBuf::new(&mut v),
            rounds: 10,
            panic_on: Some(0),
        };
        let r = catch_unwind(AssertUnwindSafe(|| pool.run(&task, |b| task.run(0, b))));
        assert!(r.is_err());
        assert!(pool.is_poisoned()); // the worker was released from its barrier
        drop(pool);
    }

    #[test]
    #[should_panic(expected = "range out of buffer")]
    fn shared_buffers_check_their_ranges() {
        let mut v = vec![0.0; 3];
        let b = SharedBuf::new(&mut v);
        // SAFETY: single-threaded; the range check fires before any access.
        let _ = unsafe { b.write(2..4) };
    }
}
