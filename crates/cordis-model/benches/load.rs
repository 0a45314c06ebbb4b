//! Loading speed and memory: a 100,000-module model text parsed, resolved and validated
//! (`load_str`), then compiled (`Model::compile`), against the targets of under 1 s and under
//! 200 bytes per module.
//!
//! ```text
//! cargo bench -p cordis-model --bench load                  # every model
//! cargo bench -p cordis-model --bench load -- ring string   # a selection
//! cargo bench -p cordis-model --bench load -- --write DIR   # also write the texts to DIR/*.cordis
//! cargo bench -p cordis-model --bench load -- --load FILE [--compile]
//!                        # only load (and compile) FILE once: for the peak RSS of `/usr/bin/time`
//! ```
//!
//! Models, generated in memory (a module is a material, link, force input or output):
//! - `ring`: one `sol`, 49,999 `mas` and 50,000 `ref` (a ring of masses, one tied to the ground)
//!   and one `sox`: 100,001 modules, one statement each;
//! - `string`: `string s n=49999`: 49,999 masses, 2 grounds, 50,000 links and one `sox`
//!   (100,002 modules from one statement);
//! - `membrane`: `membrane mem rows=316 cols=316`: 99,856 masses, a rim, 200,344 links and one
//!   `sox` (300,202 modules from one statement).
//!
//! Each model is loaded and compiled 5 times; the medians are printed. Memory comes from a counting
//! global allocator, switched on for one extra load and compile only (the timed runs pay nothing
//! for it): bytes requested and still live after `load_str` returns (the `Model`, its copy of the
//! text included), and the peak of live bytes while it runs, per module; the same for `compile`
//! (the `Engine`). These are bytes asked of the allocator: its own overhead is not counted.
#![allow(clippy::unwrap_used)] // tests and benches may panic on failure

use std::alloc::{GlobalAlloc, Layout, System};
use std::fmt::Write as _;
use std::hint::black_box;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::Relaxed};
use std::time::{Duration, Instant};

use cordis_model::{load_str, Options};

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static ALLOCS: AtomicUsize = AtomicUsize::new(0);
/// Counting is on only for the memory run, so that the timed runs pay nothing for it.
static COUNTING: AtomicBool = AtomicBool::new(false);

fn grew(n: usize) {
    if !COUNTING.load(Relaxed) {
        return;
    }
    ALLOCS.fetch_add(1, Relaxed);
    let now = LIVE.fetch_add(n, Relaxed) + n;
    PEAK.fetch_max(now, Relaxed);
}

fn shrank(n: usize) {
    if COUNTING.load(Relaxed) {
        LIVE.fetch_sub(n, Relaxed);
    }
}

// SAFETY: every call is forwarded to `System` with the caller's arguments; the counters only
// observe sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        shrank(layout.size());
        // SAFETY: forwarded unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size >= layout.size() {
            grew(new_size - layout.size());
        } else {
            shrank(layout.size() - new_size);
        }
        // SAFETY: forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Makes a model text.
type Generator = fn() -> String;

const RUNS: usize = 5;
const TARGET_S: f64 = 1.0;
const TARGET_BYTES: f64 = 200.0;

fn ring(masses: usize) -> String {
    let mut t = String::new();
    t.push_str("# a ring of masses tied to one ground\nrate 44100\nduration 1s\nsol g X0=0\n");
    for i in 0..masses {
        let v0 = if i == masses / 4 { " V0=1" } else { "" };
        writeln!(t, "mas m{i} M=1 X0=0{v0}").unwrap();
    }
    writeln!(t, "ref rg g m0 K=0.1 Z=0.0001").unwrap();
    for i in 0..masses {
        let j = (i + 1) % masses;
        writeln!(t, "ref r{i} m{i} m{j} K=0.1 Z=0.0001").unwrap();
    }
    writeln!(t, "sox out m{}", masses / 2).unwrap();
    t
}

fn string(n: usize) -> String {
    format!(
        "rate 44100\nstring s n={n} M=1 K=0.1 Z=0.0001 pluck=({}, 1)\nsox out s[{}]\n",
        n / 4,
        n / 2
    )
}

fn membrane(side: usize) -> String {
    format!(
        "rate 44100\nmembrane mem rows={side} cols={side} M=1 K=0.1 Z=0.0001\ninit mem[2,2] V0=1\nsox out mem[{},{}]\n",
        side / 2,
        side / 2
    )
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}

fn bench(name: &str, text: &str) {
    let path = Path::new("bench.cordis");
    let opts = Options::default();

    // memory: one load and compile, counted
    LIVE.store(0, Relaxed);
    PEAK.store(0, Relaxed);
    COUNTING.store(true, Relaxed);
    let before = LIVE.load(Relaxed);
    let allocs0 = ALLOCS.load(Relaxed);
    let model = load_str(path, text, &opts).unwrap();
    let after = LIVE.load(Relaxed);
    let peak = PEAK.load(Relaxed);
    let allocs = ALLOCS.load(Relaxed) - allocs0;
    let modules = model.network.module_count();
    PEAK.store(after, Relaxed);
    let engine = model.compile();
    let engine_live = LIVE.load(Relaxed) - after;
    let engine_peak = PEAK.load(Relaxed) - after;
    COUNTING.store(false, Relaxed);
    drop(engine);
    drop(model);

    // time
    let (mut load_t, mut compile_t) = (Vec::new(), Vec::new());
    for _ in 0..RUNS {
        let t0 = Instant::now();
        let model = black_box(load_str(path, black_box(text), &opts).unwrap());
        let t1 = Instant::now();
        let engine = black_box(model.compile());
        let t2 = Instant::now();
        load_t.push(secs(t1 - t0));
        compile_t.push(secs(t2 - t1));
        drop(engine);
        drop(model);
    }
    let (lo, hi) = (
        load_t.iter().copied().fold(f64::INFINITY, f64::min),
        load_t.iter().copied().fold(0.0, f64::max),
    );
    let load = median(&mut load_t);
    let compile = median(&mut compile_t);
    let per = |b: usize| b as f64 / modules as f64;
    let live = after - before;
    let peak = peak - before;
    println!(
        "{name:<9} {modules:>7} modules, {:>8} bytes of text ({:.1} per module)",
        text.len(),
        per(text.len())
    );
    println!(
        "  load     {:>8.1} ms (min {:.1}, max {:.1})   {:>6.0} ns/module   load / 1 s = {:.3}",
        load * 1e3,
        lo * 1e3,
        hi * 1e3,
        load * 1e9 / modules as f64,
        load / TARGET_S
    );
    println!(
        "  compile  {:>8.1} ms   load + compile = {:.1} ms ({:.3} of 1 s)",
        compile * 1e3,
        (load + compile) * 1e3,
        (load + compile) / TARGET_S
    );
    println!(
        "  memory   model live {:>6.1} B/module ({:.2} MB)   peak during load {:>6.1} B/module ({:.2} MB)   target {TARGET_BYTES:.0}: live {}, peak {}",
        per(live),
        live as f64 / 1e6,
        per(peak),
        peak as f64 / 1e6,
        if per(live) < TARGET_BYTES { "met" } else { "NOT met" },
        if per(peak) < TARGET_BYTES { "met" } else { "NOT met" },
    );
    println!(
        "           {:.2} allocations/module during load;   engine live {:.1} B/module, peak during compile {:.1} B/module",
        allocs as f64 / modules as f64,
        per(engine_live),
        per(engine_peak)
    );
    let ready = per(live + engine_live);
    println!(
        "  ready to run (model + engine live) {ready:.1} B/module   target {TARGET_BYTES:.0}: {}",
        if ready < TARGET_BYTES {
            "met"
        } else {
            "NOT met"
        }
    );
}

fn main() {
    let mut args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut write_to = None;
    if let Some(i) = args.iter().position(|a| a == "--write") {
        write_to = Some(args.get(i + 1).expect("--write DIR").clone());
        args.drain(i..(i + 2).min(args.len()));
    }
    if let Some(i) = args.iter().position(|a| a == "--load") {
        // one load (and compile, with --compile) of a file, nothing else: for the peak RSS that
        // `/usr/bin/time -f %M` reports
        let file = args.get(i + 1).expect("--load FILE");
        let model = cordis_model::load_file(Path::new(file), &Options::default()).unwrap();
        if args.iter().any(|a| a == "--compile") {
            black_box(model.compile());
        }
        println!("{} modules", model.network.module_count());
        return;
    }
    let models: [(&str, Generator); 3] = [
        ("ring", || ring(49_999)),
        ("string", || string(49_999)),
        ("membrane", || membrane(316)),
    ];
    println!(
        "cordis-model load bench: median of {RUNS}; targets: load < {TARGET_S} s, memory < {TARGET_BYTES} B/module"
    );
    if let Ok(l) = std::fs::read_to_string("/proc/loadavg") {
        println!("load average: {}", l.trim());
    }
    for (name, make) in models {
        if !args.is_empty() && !args.iter().any(|a| a == name) {
            continue;
        }
        let text = make();
        if let Some(dir) = &write_to {
            let file = Path::new(dir).join(format!("{name}.cordis"));
            std::fs::write(&file, &text).unwrap();
            println!("wrote {}", file.display());
        }
        bench(name, &text);
    }
}
