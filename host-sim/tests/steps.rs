//! The step side (`hollowpath::app::steps`) driven as a controller drives it: a step
//! interrupt that runs every alarm at its deadline, preempting the layer's generator, whose
//! work costs time on the same clock. A generator that keeps ahead gives the telemetry of
//! `simulate` exactly and no starved alarm; one far slower than the print starves, is
//! counted, and still prints the same path within the printer's limits.

use std::path::Path;

use hollowpath::app::job::{self, Drive, Printed};
use hollowpath::app::steps::Stepping;
use hollowpath::motion::stepper::before;
use hollowpath::motion::{PrinterConfig, State};
use hollowpath::toolpath::offset::OffsetSpiral;
use hollowpath::{Plan, Slice};
use host_sim::virtual_printer::{self, rebuild, Rebuild, VirtualBoard, VirtualPrinter};
use host_sim::{printer_file, slice_file};

/// The controller's clock: the generator's every call into the step side costs `cost`
/// ticks, and before it the interrupt runs every alarm that fell due meanwhile, each at its
/// deadline (the board's clock set there).
struct Interrupted<'a> {
    steps: Box<Stepping<&'a mut VirtualBoard>>,
    /// The controller's time, ticks.
    now: u32,
    /// The board's clock (where the last alarm ran), ticks.
    board_at: u32,
    cost: u32,
}

impl Interrupted<'_> {
    /// The interrupt: every alarm due by `now`.
    fn run_due(&mut self) {
        while let Some(d) = self.steps.deadline() {
            if before(self.now, d) {
                break;
            }
            let dt = d.wrapping_sub(self.board_at);
            self.steps.board().advance(dt as u64);
            self.board_at = d;
            self.steps.on_alarm(d);
        }
    }
}

impl<'a> Drive for Interrupted<'a> {
    type Board = &'a mut VirtualBoard;
    type Stop = String;
    fn lock<R>(&mut self, f: impl FnOnce(&mut Stepping<Self::Board>) -> R) -> R {
        self.now = self.now.wrapping_add(self.cost);
        self.run_due();
        f(&mut self.steps)
    }
    fn now(&mut self) -> u32 {
        self.now
    }
    fn kick(&mut self) {
        self.run_due();
    }
    fn wait(&mut self) -> Result<(), String> {
        // Sleep until the next deadline.
        match self.steps.deadline() {
            Some(d) => {
                if before(self.now, d) {
                    self.now = d;
                }
                self.run_due();
                Ok(())
            }
            None => Err(format!(
                "waiting at rest: {:?}, cost {}, done {}, planner {}",
                self.steps.state(),
                self.cost,
                self.steps.layer_done(),
                self.steps.machine().map(|m| m.planner().len()).unwrap_or(0)
            )),
        }
    }
}

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

/// Prints `layers` layers of `slice` with a generator costing `cost` ticks per call; per
/// layer what it drove, and the trace of the whole job.
fn print_interrupted(
    cfg: &PrinterConfig,
    slice: &Slice,
    plan: &Plan,
    layers: usize,
    cost: u32,
) -> (Vec<Printed>, virtual_printer::Trace) {
    let VirtualPrinter {
        machine, mut board, ..
    } = VirtualPrinter::new(cfg).unwrap();
    board.take_trace();
    let printed = {
        let mut steps = Box::new(Stepping::new(&mut board));
        steps.install(*machine);
        let mut drive = Interrupted {
            steps,
            now: 0,
            board_at: 0,
            cost,
        };
        let mut offset = Box::new(OffsetSpiral::new());
        let mut grid = Box::new(hollowpath::field::GridMemory::new());
        let printed: Vec<Printed> = (0..layers)
            .map(|k| job::print_layer(slice, plan, &mut offset, &mut grid, k, &mut drive).unwrap())
            .collect();
        assert_eq!(drive.steps.state(), Some(State::Ready));
        printed
    };
    (printed, board.take_trace())
}

#[test]
fn a_generator_that_keeps_ahead_prints_what_simulate_counts_and_a_slow_one_starves_safely() {
    host_sim::run_on_large_stack(|| {
        let cfg = printer_file::load(&data("ci_printer.json")).unwrap();
        for name in ["four_holes", "vessel_ring"] {
            let slice = slice_file::load(&data(&format!("{name}.json")))
                .unwrap()
                .slice;
            let planner = host_sim::plan(&slice).unwrap();
            let plan = planner.last_plan();
            let want = virtual_printer::run_job_counted(&cfg, &slice, plan, 2).unwrap();
            assert!(want.iter().all(|p| p.starved == 0), "{name}: {want:?}");

            // 20 us of generator work per queued move: far ahead of a 40 mm/s print.
            let (fast, _) = print_interrupted(&cfg, &slice, plan, 2, 20);
            assert_eq!(fast, want, "{name}: a generator that keeps ahead");

            // 40 ms per call: the look-ahead runs dry again and again.
            let (slow, trace) = print_interrupted(&cfg, &slice, plan, 2, 40_000);
            for (k, (s, w)) in slow.iter().zip(&want).enumerate() {
                assert!(s.starved > 0, "{name} layer {k}: {s:?}");
                // The same blocks, so the same steps; stops and restarts take longer.
                assert_eq!(s.counters.steps, w.counters.steps, "{name} layer {k}");
                assert!(s.counters.ticks > w.counters.ticks, "{name} layer {k}");
            }
            // Within the printer's step rate (a stop at speed would show as a burst).
            let fig = rebuild(&cfg, &trace, &Rebuild::for_road_width(0.4)).figures;
            let fastest = cfg
                .axes
                .iter()
                .map(|a| a.max_speed * a.steps_per_mm)
                .fold(0.0f32, f32::max) as f64;
            assert!(
                fig.max_step_rate_hz <= fastest * 1.01,
                "{name}: {} Hz over {fastest} Hz",
                fig.max_step_rate_hz
            );
            assert!(fig.min_pulse_ticks >= 1, "{name}");
            eprintln!(
                "{name}: starved alarms {:?}, print ticks {:?} (keeping ahead: {:?})",
                slow.iter().map(|p| p.starved).collect::<Vec<_>>(),
                slow.iter().map(|p| p.counters.ticks).collect::<Vec<_>>(),
                want.iter().map(|p| p.counters.ticks).collect::<Vec<_>>()
            );
        }
    });
}
