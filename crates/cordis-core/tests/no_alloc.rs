//! `Engine::process` never allocates (STYLE.md practice 3): a counting global allocator watches it,
//! on the calling thread and, with threads, on every thread of the process.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

struct Counting;

/// Counts allocations on every thread while set (the engine's workers included). This binary has
/// a single test, so that no other test (nor the harness reporting one) allocates meanwhile.
static WATCH_ALL: AtomicBool = AtomicBool::new(false);
static COUNT_ALL: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static WATCH: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if WATCH_ALL.load(Ordering::Relaxed) {
            COUNT_ALL.fetch_add(1, Ordering::Relaxed);
        }
        // try_with: the thread-local may already be gone while a thread shuts down.
        let _ = WATCH.try_with(|w| {
            if w.get() {
                COUNT.with(|c| c.set(c.get() + 1));
            }
        });
        // SAFETY: forwarding the caller's layout to the system allocator unchanged.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout (see `alloc`).
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn process_does_not_allocate() {
    single_thread_process_does_not_allocate();
    threaded_process_does_not_allocate_on_any_thread();
}

fn single_thread_process_does_not_allocate() {
    // (the second takes the pull step on an AVX-512 CPU)
    for net in [
        common::every_module_network(),
        common::spring_network(1, 100, 4, 3, false),
    ] {
        let mut e = cordis_core::Engine::new(&net);
        let mut out = vec![0.0; 512 * e.channels()];
        WATCH.with(|w| w.set(true));
        for _ in 0..20 {
            e.process(512, &mut out).unwrap();
        }
        WATCH.with(|w| w.set(false));
        assert_eq!(COUNT.with(|c| c.get()), 0, "allocations during process");
    }
    // the counter works: an allocation while watching is seen
    WATCH.with(|w| w.set(true));
    let v: Vec<u8> = Vec::with_capacity(10);
    WATCH.with(|w| w.set(false));
    drop(v);
    assert!(COUNT.with(|c| c.get()) > 0);
}

fn threaded_process_does_not_allocate_on_any_thread() {
    let net = common::random_network(3, 2000, 4);
    for threads in [2, 3] {
        let mut e = cordis_core::Engine::new(&net);
        e.set_parallel_threshold(0);
        e.set_threads(threads); // starts the workers: allocates, before watching
        assert!(e.is_parallel());
        let mut out = vec![0.0; 64 * e.channels()];
        COUNT_ALL.store(0, Ordering::Relaxed);
        WATCH_ALL.store(true, Ordering::Relaxed);
        for block in [1, 7, 64, 2, 64] {
            e.process(block, &mut out[..block * e.channels()]).unwrap();
        }
        std::thread::sleep(std::time::Duration::from_millis(5)); // workers go idle and park
        e.process(64, &mut out).unwrap();
        WATCH_ALL.store(false, Ordering::Relaxed);
        assert_eq!(
            COUNT_ALL.load(Ordering::Relaxed),
            0,
            "allocations during process with {threads} threads"
        );
    }
    // the counter works: an allocation on another thread while watching is seen
    WATCH_ALL.store(true, Ordering::Relaxed);
    std::thread::scope(|s| {
        s.spawn(|| drop(Vec::<u8>::with_capacity(10)));
    });
    WATCH_ALL.store(false, Ordering::Relaxed);
    assert!(COUNT_ALL.load(Ordering::Relaxed) > 0);
}
