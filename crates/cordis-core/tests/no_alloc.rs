//! `Engine::process` never allocates (STYLE.md practice 3): a counting global allocator watches it.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static WATCH: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
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
    let net = common::every_module_network();
    let mut e = cordis_core::Engine::new(&net);
    let mut out = vec![0.0; 512 * e.channels()];
    WATCH.with(|w| w.set(true));
    for _ in 0..20 {
        e.process(512, &mut out).unwrap();
    }
    WATCH.with(|w| w.set(false));
    assert_eq!(COUNT.with(|c| c.get()), 0, "allocations during process");
    // the counter works: an allocation while watching is seen
    WATCH.with(|w| w.set(true));
    let v: Vec<u8> = Vec::with_capacity(10);
    WATCH.with(|w| w.set(false));
    drop(v);
    assert!(COUNT.with(|c| c.get()) > 0);
}
