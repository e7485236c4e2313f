//! The link over a lossy line: frames dropped, corrupted, duplicated and reordered in both
//! directions, delivered in random pieces; both ends must deliver the exact message sequence
//! once and in order. And the decoders fed random and mutated bytes.

#[path = "link_support/mod.rs"]
mod link_support;

use link_support::{ctrl_messages, fuzz_case, host_messages, simulate, CtrlEnd, Faults, Rng};
use proptest::prelude::*;

#[test]
fn clean_line_needs_no_retransmission() {
    let mut rng = Rng::new(1);
    let up = host_messages(50, &mut rng);
    let down = ctrl_messages(50);
    let o = simulate(7, Faults::default(), &up, &down, 60_000_000);
    assert_eq!(o.ctrl_got, up);
    assert_eq!(o.host_got, down);
    assert_eq!(o.host.retransmissions + o.ctrl.retransmissions, 0);
    assert_eq!(o.host.crc_errors + o.ctrl.crc_errors, 0);
}

#[test]
fn heavy_loss_is_recovered_and_counted() {
    let mut rng = Rng::new(2);
    let up = host_messages(60, &mut rng);
    let down = ctrl_messages(60);
    let faults = Faults {
        drop: 200,
        corrupt: 200,
        duplicate: 200,
        reorder: 200,
    };
    let o = simulate(11, faults, &up, &down, 600_000_000);
    assert_eq!(o.ctrl_got, up);
    assert_eq!(o.host_got, down);
    assert!(o.lost_data > 0);
    assert!(o.host.retransmissions > 0 && o.ctrl.retransmissions > 0);
    assert!(o.host.duplicates + o.ctrl.duplicates > 0);
    assert!(
        o.host.crc_errors + o.ctrl.crc_errors + o.host.framing_errors + o.ctrl.framing_errors > 0
    );
    println!(
        "60 + 60 messages over a 20 %-drop, 20 %-corrupt, 20 %-duplicate, 20 %-reorder line: \
         {} + {} retransmissions, {} + {} naks, {:.1} s",
        o.host.retransmissions,
        o.ctrl.retransmissions,
        o.host.naks_sent,
        o.ctrl.naks_sent,
        o.elapsed_us as f64 * 1e-6
    );
}

/// Found by `lossy_line_delivers_everything_once_in_order` in CI: a "damaged" data frame whose
/// damage left it readable (a repeated or inserted delimiter, for one, only adds an empty frame
/// beside it) arrived, was delivered and needed no retransmission, and the line counted it
/// lost. The line now counts a damaged frame lost only if its bytes no longer hold it. The
/// drawn case, through the property's own check.
#[test]
fn a_frame_damaged_but_still_readable_is_not_counted_lost() {
    let faults = Faults {
        drop: 0,
        corrupt: 10,
        duplicate: 72,
        reorder: 0,
    };
    delivers_everything_once_in_order(18_122_015_875_642_980_010, faults, 5, 2);
}

/// `n_up` host messages and `n_down` controller messages over a line with `faults` (the
/// line's and the messages' randomness from `seed`): both ends deliver the exact sequence
/// once and in order, and every data frame lost or damaged past reading was sent again.
fn delivers_everything_once_in_order(seed: u64, faults: Faults, n_up: usize, n_down: usize) {
    let mut rng = Rng::new(seed ^ 0x5eed);
    let up = host_messages(n_up, &mut rng);
    let down = ctrl_messages(n_down);
    let o = simulate(seed, faults, &up, &down, 900_000_000);
    assert_eq!(o.ctrl_got, up);
    assert_eq!(o.host_got, down);
    assert!(o.lost_data == 0 || o.host.retransmissions + o.ctrl.retransmissions > 0);
    assert_eq!(o.ctrl.delivered as usize, up.len());
    assert_eq!(o.host.delivered as usize, down.len());
}

#[test]
fn sequence_numbers_wrap_under_loss() {
    // 700 messages each way: the u8 sequence numbers wrap twice.
    let mut rng = Rng::new(3);
    let up = host_messages(700, &mut rng);
    let down = ctrl_messages(700);
    let faults = Faults {
        drop: 50,
        corrupt: 50,
        duplicate: 50,
        reorder: 50,
    };
    let o = simulate(5, faults, &up, &down, 3_000_000_000);
    println!(
        "700 + 700 messages: {} + {} retransmissions, {} data frames lost, {:.1} s",
        o.host.retransmissions,
        o.ctrl.retransmissions,
        o.lost_data,
        o.elapsed_us as f64 * 1e-6
    );
    assert_eq!(o.ctrl_got, up);
    assert_eq!(o.host_got, down);
    assert!(o.host.retransmissions > 0 && o.ctrl.retransmissions > 0);
}

#[test]
fn timers_for_a_baud_rate() {
    let c = hollowpath::link::endpoint::LinkConfig::for_baud(115_200, 4);
    // A full window of the largest frames (4 x 525 bytes) is 182 ms at 115 200 baud.
    assert!(
        c.retransmit_us > 2 * 182_000 && c.retransmit_us < 450_000,
        "{c:?}"
    );
    assert!(c.keepalive_us < c.watchdog_us && c.watchdog_us >= 1_000_000);
    let fast = hollowpath::link::endpoint::LinkConfig::for_baud(1_000_000, 4);
    assert!(fast.retransmit_us < c.retransmit_us);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn lossy_line_delivers_everything_once_in_order(
        seed in any::<u64>(),
        drop in 0u32..250,
        corrupt in 0u32..250,
        duplicate in 0u32..250,
        reorder in 0u32..250,
        n_up in 0usize..40,
        n_down in 0usize..40,
    ) {
        let faults = Faults { drop, corrupt, duplicate, reorder };
        delivers_everything_once_in_order(seed, faults, n_up, n_down);
    }

    #[test]
    fn decoders_never_panic_nor_accept_a_frame_never_sent(seed in any::<u64>()) {
        let mut rng = Rng::new(seed);
        let mut end = CtrlEnd::new(link_support::SIM_CONFIG);
        for _ in 0..64 {
            if let Err(e) = fuzz_case(&mut rng, &mut end) {
                prop_assert!(false, "{}", e);
            }
        }
    }
}
