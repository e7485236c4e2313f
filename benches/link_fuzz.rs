//! The link's decoders under a million fuzz cases: real frames mutated (bit flips, a byte
//! replaced, inserted or removed), pure noise, and the payloads through the message and
//! contour decoders. Fails (exit status 1) if any case panics or a frame other than the one
//! sent is accepted; then a few hundred lossy-line simulations.
//!
//! `cargo bench -p hollowpath --bench link_fuzz` (`-- CASES SEED` to choose).

#[path = "../tests/link_support/mod.rs"]
mod link_support;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use link_support::{ctrl_messages, fuzz_case, host_messages, simulate, CtrlEnd, Faults, Rng};

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let cases: u64 = args
        .first()
        .and_then(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    let seed: u64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(0x11_1ce);
    let t = Instant::now();
    let mut rng = Rng::new(seed);
    let mut end = CtrlEnd::new(link_support::SIM_CONFIG);
    let mut failures = 0u64;
    for case in 0..cases {
        let before = rng.clone();
        match catch_unwind(AssertUnwindSafe(|| fuzz_case(&mut rng, &mut end))) {
            Ok(Ok(())) => {}
            Ok(Err(e)) => {
                failures += 1;
                println!("case {case} (rng {before:?}): {e}");
            }
            Err(_) => {
                failures += 1;
                println!("case {case} (rng {before:?}): panicked");
                end = CtrlEnd::new(link_support::SIM_CONFIG);
            }
        }
    }
    let s = end.stats();
    println!(
        "link_fuzz: {cases} cases (seed {seed}), {failures} failures, {:.1} s; the link end took {} frames, dropped {} on CRC and {} as malformed",
        t.elapsed().as_secs_f64(),
        s.frames_received,
        s.crc_errors,
        s.framing_errors
    );
    let t = Instant::now();
    let mut sims = 0;
    let (mut retransmissions, mut lost) = (0u64, 0u64);
    for k in 0..300u64 {
        let mut r = Rng::new(seed ^ k);
        let up = host_messages(r.below(40), &mut r);
        let down = ctrl_messages(r.below(40));
        let f = Faults {
            drop: r.below(300) as u32,
            corrupt: r.below(300) as u32,
            duplicate: r.below(300) as u32,
            reorder: r.below(300) as u32,
        };
        let o = simulate(seed ^ (k << 20), f, &up, &down, 900_000_000);
        sims += 1;
        retransmissions += u64::from(o.host.retransmissions + o.ctrl.retransmissions);
        lost += u64::from(o.lost_data);
        if o.ctrl_got != up || o.host_got != down {
            failures += 1;
            println!(
                "simulation {k} ({f:?}): delivered {} of {} up, {} of {} down",
                o.ctrl_got.len(),
                up.len(),
                o.host_got.len(),
                down.len()
            );
        }
    }
    println!(
        "link_fuzz: {sims} lossy-line simulations, {lost} data frames lost or damaged, {retransmissions} retransmissions, {:.1} s",
        t.elapsed().as_secs_f64()
    );
    if failures > 0 {
        println!("link_fuzz: {failures} FAILURES");
        std::process::exit(1);
    }
}
