//! The array firmware on QEMU's lm3s6965evb (Cortex-M4): sixteen sensors
//! read at once through one comb excitation ([`instrument::array`]), with
//! the simulated skin of [`firmware::array_skin`] in place of the board's
//! DAC, transimpedance stages and five scanning ADCs.
//!
//! * `dma_done` (hardware task, bound to the GPIOA interrupt, pended by
//!   `idle` as the board's DMA-complete interrupt would fire): a block of
//!   the five ADCs' scans is complete; the simulated DMA has filled it.
//!   Logs each sensor's truth (the rig's view).
//! * `process` (software task): demodulate the comb on the excitation and
//!   on every sensor's input, turn each sensor's two tones into a line
//!   with its model check ([`instrument::tones`]), and queue the records.
//! * `idle`: the logger. It drains the record queue (a `heapless` SPSC
//!   queue of [`QUEUE`] − 1 records, four blocks' worth) to defmt. The
//!   acquisition never waits for it: a record that finds the queue full
//!   is dropped and counted, and a `drops n` line says so.
//!
//! Records are `tone` lines of [`instrument::wire`], decoded on the host.
//! The scenario is the first semihosting argument (`paper`, `check`,
//! `hum`, `identify`, `skin`, `stairs`). Without further arguments the firmware
//! measures with the test rig's description of its skin
//! ([`ArrayScenario::rig`]) in 4 ms blocks (250 records/s; `records=1000`:
//! 1 ms blocks, [`Layout::BLOCK_1MS`]; `seconds=S`: S whole seconds
//! of the scenario, less than all of it or it repeated; `offset_us=N`, `drift_ppm=N`:
//! the records stamped by a clock that is off true time, as another
//! board's would be, [`DeviceClock`]); `flash=PATH` keeps the settings' flash in a
//! host file ([`firmware::qemu_flash`]) and measures with the set stored
//! there (uncalibrated with none; `save` stores the rig's first;
//! `until-stop` measures past the scenario's end until the host stops
//! it), and `idle` answers the host's requests down the link (UART0's receive
//! side): read and write the stored settings, stop. The skin, the reader
//! and the block are built where they stay ([`qemu::place`]), so that
//! `init` leaves the stack to the store's path.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use dsp_core::comb::CombError;
use firmware::array_skin::{ArrayScenario, ArraySkin, BoardFault};
use firmware::device_clock::DeviceClock;
use firmware::in_force::InForce;
use firmware::power_up::PowerUp;
use firmware::qemu::{self, LinkSender, Uart0};
use firmware::qemu_flash::{self, FileFlash, FlashArgs};
use firmware::records::{RecordSink, QUEUE};
use heapless::spsc::{Consumer, Queue};
use heapless::Vec;
use instrument::array::{Frame, Layout, ADCS, BLOCK_INSTANTS, INPUTS, RATE_HZ, SCAN, SENSORS};
use instrument::busy::Busy;
use instrument::calib::POINTS;
use instrument::commands::Commands;
use instrument::frames;
use instrument::reader::{ArrayReader, Demodulated};
use instrument::sensor::Sensors;
use instrument::store::Store;
use instrument::sweep::Sweep;
use instrument::tones::{ToneCommon, ToneRecord, ToneSettings};
use instrument::wire;

/// How many times over a run may go through its scenario (`seconds=`):
/// past its length a scenario's motion repeats (its profiles are
/// periodic or held).
const REPEATS: f32 = 6.0;

/// What the command line asks for.
struct Arguments {
    /// The scenario named by the first semihosting argument.
    scenario: ArrayScenario,
    /// The blocks' layout: `records=250` (the default) or `records=1000`.
    layout: Layout,
    /// How long to simulate, s: `seconds=S` (whole seconds, more than 0,
    /// at most [`REPEATS`] times the scenario's duration, which is the
    /// default; an integer
    /// keeps core's float parser out of the image).
    duration_s: f32,
    /// The settings' options (`flash=PATH`, `save`, `until-stop`).
    flash: FlashArgs,
    /// The device's clock (`offset_us=N`, `drift_ppm=N`): what it
    /// stamps its records with.
    clock: DeviceClock,
    /// A board assembled wrong (`fault=reference`, `fault=stage`): the
    /// self-test's failing cases.
    fault: Option<BoardFault>,
}

/// The command line: the scenario first, then its options; a run with
/// an argument it does not know ends with exit code 2.
fn arguments() -> Arguments {
    qemu::with_args(|args| {
        let name = args.next().unwrap_or("paper");
        let scenario = ArrayScenario::parse(name).unwrap_or_else(|| {
            defmt::println!("unknown scenario {=str}", name);
            qemu::exit(2)
        });
        let mut flash = FlashArgs::default();
        let mut clock = DeviceClock::default();
        let mut layout = Layout::BLOCK_4MS;
        let mut duration_s = scenario.duration_s();
        let mut fault = None;
        for arg in args {
            if let Some(name) = arg.strip_prefix("fault=") {
                fault = BoardFault::parse(name);
                if fault.is_none() {
                    defmt::println!("fault=: reference or stage, not '{=str}'", name);
                    qemu::exit(2)
                }
            } else if let Some(rate) = arg.strip_prefix("records=") {
                match rate.parse().ok().and_then(Layout::of_records_per_s) {
                    Some(l) => layout = l,
                    None => {
                        defmt::println!("records=: 250 or 1000 records/s, not '{=str}'", rate);
                        qemu::exit(2)
                    }
                }
            } else if let Some(s) = arg.strip_prefix("seconds=") {
                match s.parse::<u16>() {
                    Ok(v) if v > 0 && v as f32 <= REPEATS * scenario.duration_s() => duration_s = v as f32,
                    _ => {
                        defmt::println!(
                            "seconds=: whole seconds, more than 0, at most six times the scenario's, not '{=str}'",
                            s
                        );
                        qemu::exit(2)
                    }
                }
            } else if let Some(taken) = clock.take(arg) {
                if let Err(why) = taken {
                    defmt::println!("{=str}, not '{=str}'", why, arg);
                    qemu::exit(2)
                }
            } else if !flash.take(arg) {
                defmt::println!("unknown argument '{=str}'", arg);
                qemu::exit(2)
            }
        }
        Arguments {
            scenario,
            layout,
            duration_s,
            flash,
            clock,
            fault,
        }
    })
}

/// Each record the queue holds, to defmt and to the link.
fn log_records(logger: &mut Consumer<'static, ToneRecord, QUEUE>, link: &mut LinkSender) {
    while let Some(rec) = logger.dequeue() {
        defmt::println!("{}", rec);
        link.record(frames::from_tone_record(&rec));
    }
}

#[rtic::app(device = lm3s6965, dispatchers = [SSI0])]
mod app {
    use super::*;
    use lm3s6965::Interrupt;

    #[shared]
    struct Shared {
        /// The block the DMA completed, its clipped inputs and its middle.
        frame: (&'static mut Frame, [bool; INPUTS], u64),
        done: bool,
        /// Records the queue had no room for.
        dropped: u32,
        /// A calibration step's sweep of the tone pairs, if one is under
        /// way.
        sweep: Sweep,
        /// How the CPU keeps up: blocks' times, late and missed ones.
        busy: Busy,
        /// The status due on the link, if one is.
        status: Option<link::Status>,
        /// The settings and sensors measured with, replaced by `idle`
        /// when the host stores a new set.
        in_force: InForce<ToneCommon, SENSORS>,
        /// The self-test's result, for the start frame, once it is done.
        self_test: Option<link::SelfTest>,
    }

    #[local]
    struct Local {
        skin: &'static mut ArraySkin,
        block: u64,
        end_block: u64,
        reader: &'static mut ArrayReader,
        /// The block period, µs.
        block_us: u64,
        records: RecordSink<'static>,
        /// The device's clock, which its records' times are read on.
        clock: DeviceClock,
        logger: Consumer<'static, ToneRecord, QUEUE>,
        link: LinkSender,
        /// The start frame, sent when the self-test is done (`None`
        /// once sent).
        start: Option<link::Start>,
        store: Option<Store<FileFlash>>,
        commands: Commands,
        /// The power-up self-test, in the first blocks.
        power_up: PowerUp,
    }

    #[init(local = [
        queue: Queue<ToneRecord, QUEUE> = Queue::new(),
        // Sixteen sensors' lines and tables (10 KiB), built in place.
        sensors: MaybeUninit<Sensors<POINTS, SENSORS>> = MaybeUninit::uninit(),
        // The simulated skin (6.5 KiB), the reader (10 KiB) and the
        // block (4 KiB) where they stay, off `init`'s stack.
        skin_slot: MaybeUninit<ArraySkin> = MaybeUninit::uninit(),
        reader_slot: MaybeUninit<Result<ArrayReader, CombError>> = MaybeUninit::uninit(),
        frame_slot: Frame = [[[0; SCAN]; BLOCK_INSTANTS]; ADCS],
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        firmware::stack::paint();
        qemu::Instructions::start(cx.core.SYST);
        let (records, logger) = cx.local.queue.split();
        let Arguments {
            scenario,
            layout,
            duration_s,
            flash,
            clock,
            fault,
        } = arguments();
        let skin = qemu::place(cx.local.skin_slot, || ArraySkin::new(scenario, layout));
        skin.set_fault(fault);
        let Ok(rig) = scenario.rig() else { qemu::exit(3) };
        let (store, (generation, set)) = flash.set_in_force(&rig);
        let Ok(sensors) = firmware::settings_log::sensors_in(cx.local.sensors, &set) else {
            defmt::println!("settings: a tab-lead ratio beyond the line model's range");
            qemu::exit(2)
        };
        let Some(reader) = qemu::place_reader(cx.local.reader_slot, layout, sensors, firmware::MAINS_HZ)
        else {
            qemu::exit(3)
        };
        let common = ToneCommon {
            policy: set.policy,
            record_every: set.record_every,
            ..ToneSettings::new(layout, skin.front_end().dsp_front_end(), &*sensors).common()
        };
        let in_force = InForce::new(common, sensors, generation);
        let start = in_force.start_frame(
            concat!("skin-array ", env!("CARGO_PKG_VERSION")),
            flash.device,
            SENSORS,
            RATE_HZ,
        );
        defmt::println!(
            "start array {=u8} sensors, {=u32} records/s each, scenario {}",
            SENSORS as u8,
            layout.records_per_s(),
            defmt::Debug2Format(&scenario)
        );
        (
            Shared {
                frame: (cx.local.frame_slot, [false; INPUTS], 0),
                done: false,
                dropped: 0,
                sweep: Sweep::new(),
                busy: Busy::new(
                    link::Clock::Instructions,
                    instrument::design::SYSCLK_HZ,
                    layout.block_us() as u32,
                    layout.records_per_s(),
                ),
                status: None,
                in_force,
                self_test: None,
            },
            Local {
                skin,
                block: 0,
                block_us: layout.block_us(),
                // The self-test's blocks first, then the run's (saturating:
                // `until-stop` runs to u64::MAX).
                end_block: PowerUp::blocks(layout)
                    .saturating_add(flash.end_step((duration_s as f64 * 1e6) as u64 / layout.block_us())),
                reader,
                records: RecordSink::new(records),
                clock,
                logger,
                link: LinkSender::new(Uart0::take()),
                start: Some(start),
                store,
                commands: Commands::sweeping(),
                power_up: PowerUp::new(layout),
            },
        )
    }

    /// The logger: each record to defmt and to the link (UART0); the
    /// host's requests down the link answered (the stored settings, stop);
    /// the link's end frame when the run is done or the host stops it.
    #[idle(
        shared = [done, dropped, sweep, status, in_force, self_test],
        local = [logger, link, start, store, commands]
    )]
    fn idle(mut cx: idle::Context) -> ! {
        loop {
            if let Some(start) = cx.local.start.as_mut() {
                // Nothing on the link before the start frame, and it
                // waits for the self-test's result.
                match cx.shared.self_test.lock(Option::take) {
                    Some(result) => {
                        start.self_test = result;
                        cx.local.link.send_start(start);
                        *cx.local.start = None;
                    }
                    None => {
                        rtic::pend(Interrupt::GPIOA);
                        continue;
                    }
                }
            }
            log_records(cx.local.logger, cx.local.link);
            if let Some(status) = cx.shared.status.lock(Option::take) {
                cx.local.link.status(&status);
            }
            let asked = qemu_flash::answer(cx.local.link, cx.local.commands, cx.local.store.as_mut());
            if let (true, Some(store)) = (asked.apply, cx.local.store.as_mut()) {
                let (logger, link) = (&mut *cx.local.logger, &mut *cx.local.link);
                // With `process` held off: the records of the old set
                // first, then the frame, then the new set's.
                cx.shared.in_force.lock(|f| {
                    log_records(logger, link);
                    let t_us = link.last_t_us();
                    qemu_flash::apply(f, store, link, t_us);
                });
            }
            if let Some(n) = asked.sweep {
                cx.shared.sweep.lock(|s| s.start(n));
            }
            if asked.stop {
                cx.shared.done.lock(|d| *d = true);
            }
            if cx.shared.done.lock(|d| *d) {
                let dropped = cx.shared.dropped.lock(|d| *d);
                cx.local.link.end(dropped);
                qemu::end();
            }
            rtic::pend(Interrupt::GPIOA);
        }
    }

    /// DMA complete: the simulated ADCs filled the block that ends now.
    #[task(binds = GPIOA, priority = 2, shared = [frame, busy], local = [skin, block, block_us])]
    fn dma_done(mut cx: dma_done::Context) {
        let block_us = *cx.local.block_us;
        let t_us = *cx.local.block * block_us + block_us / 2;
        *cx.local.block += 1;
        let skin = &mut **cx.local.skin;
        let mut truth = [wire::TruthLine::default(); SENSORS];
        cx.shared.frame.lock(|(frame, clipped, t)| {
            *clipped = skin.block(t_us, frame, &mut truth);
            *t = t_us;
        });
        for t in &truth {
            defmt::println!("{}", t);
        }
        if process::spawn().is_err() {
            defmt::println!("overrun {=u64}", t_us);
            cx.shared.busy.lock(Busy::missed);
        }
    }

    /// Demodulate every input, solve every sensor, log the records.
    #[task(
        priority = 1,
        shared = [frame, done, dropped, sweep, busy, status, in_force, self_test],
        local = [reader, end_block, records, clock, power_up]
    )]
    async fn process(mut cx: process::Context) {
        if cx.local.power_up.testing() {
            let reader = &mut **cx.local.reader;
            let k = cx.shared.in_force.lock(|f| f.settings().front_end);
            let mut block = Demodulated::EMPTY;
            let result = cx.shared.frame.lock(|(frame, clipped, _)| {
                let layout = *reader.layout();
                reader.demodulate_into(|a| layout.rows(&frame[a]), &mut block);
                let reference = reader.reference(|a| layout.rows(&frame[a]));
                cx.local
                    .power_up
                    .block(reader, &block, &reference, |i| clipped[i], &k)
            });
            if let Some(r) = result {
                cx.shared.self_test.lock(|s| *s = Some(r));
            }
            return;
        }
        let started = qemu::Instructions::now();
        let sweep = cx.shared.sweep.lock(|s| s.next_block());
        let reader = &mut **cx.local.reader;
        // Demodulated in place (1.7 KiB: returned, it would be copied).
        let mut demodulated = Demodulated::EMPTY;
        let block = &mut demodulated;
        let (clipped, t_us) = cx.shared.frame.lock(|(frame, clipped, t)| {
            let layout = reader.layout();
            reader.demodulate_into(|a| layout.rows(&frame[a]), block);
            (*clipped, *t)
        });
        // The records' time on the device's clock; the block's end on
        // true time.
        let stamp = cx.local.clock.stamp(t_us);
        let mut recs = Vec::<ToneRecord, SENSORS>::new();
        cx.shared.in_force.lock(|f| {
            let settings = ToneSettings {
                sweep,
                ..f.settings()
            };
            reader.solve(
                &settings,
                stamp,
                block,
                |input| clipped[input],
                |rec| {
                    let _ = recs.push(rec);
                },
            );
        });
        let spent = qemu::Instructions::since(started);
        let (late, status) = cx.shared.busy.lock(|b| (b.block(spent), b.due(stamp)));
        if let Some(s) = status {
            cx.shared.status.lock(|x| *x = Some(s));
        }
        let sink = &mut *cx.local.records;
        let before = sink.drops();
        sink.push_block(&recs, late);
        if sink.drops() != before {
            defmt::println!("drops {=u32}", sink.drops());
            cx.shared.dropped.lock(|d| *d = sink.drops());
        }
        if (t_us / reader.layout().block_us()) + 1 >= *cx.local.end_block {
            cx.shared.done.lock(|d| *d = true);
        }
    }
}
