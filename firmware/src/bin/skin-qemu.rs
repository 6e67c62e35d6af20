//! The sensing-skin firmware on QEMU's lm3s6965evb (Cortex-M4), with the
//! simulated front end of [`firmware::scenario`] in place of the board's
//! multiplexer, DAC and ADC/DMA.
//!
//! * `dma_done` (hardware task, bound to the GPIOA interrupt, pended by
//!   `idle` with `rtic::pend` as the board's DMA-complete interrupt would
//!   fire): a slot is complete. The board's own sequencer
//!   ([`instrument::sequencer`]) says which slot, channel and frequency it
//!   was, which channel to select next and which frequency to prepare.
//! * `process` (software task): demodulate, correct, check faults, update
//!   the frequency policy, log the record with defmt.
//!
//! Records (defmt over semihosting, decoded on the host) are the wire
//! format of [`instrument::wire`]: a `rec` line per block and, in QEMU, a
//! `truth` line beside it (the rig's view: end-to-end electrode
//! resistances).
//! The scenario is the first semihosting argument (`-semihosting-config
//! enable=on,arg=paper20`); the optional further ones are the static
//! effects `host-sim identify` found, as `id=value` in SI units
//! (`<id>=1.2e-11`, ids from [`instrument::effects`]): the firmware de-embeds the wiring
//! they describe ([`instrument::effects::EffectSet::fixture`]).
//! `flash=PATH` keeps the settings' flash in a host file
//! ([`firmware::qemu_flash`]): the run says what is stored there, and with
//! `save` stores the settings it measures with; `until-stop` measures
//! past the scenario's end until the host's stop request. Requests down the link
//! (UART0's receive side: read and write the stored settings, stop) are
//! answered after each block ([`instrument::commands`]).
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use dsp_core::fixture::Fixture;
use firmware::in_force::InForce;
use firmware::qemu::{self, LinkSender, Uart0};
use firmware::qemu_flash::{self, FileFlash, FlashArgs};
use firmware::scenario::{mux_pins, range_pins, Scenario, SimPin, Skin};
use instrument::busy::Busy;
use instrument::calib::POINTS;
use instrument::channel::{Channel, Common, Settings};
use instrument::commands::Commands;
use instrument::config::{BLOCK_PAIRS, CHANNELS, MUX_ADDRESS_LINES, RANGE_ADDRESS_LINES, SLOT_PAIRS};
use instrument::design::SENSOR_R_REST_OHM;
use instrument::effects::{Effect, EffectSet};
use instrument::frames;
use instrument::mux::Mux;
use instrument::policy::Policy;
use instrument::reader::{MuxReader, Read};
use instrument::sensor::{Sensor, Sensors};
use instrument::sequencer::{pairs_us, Sequencer, Slot, SLOTS_PER_S, SLOT_US};
use instrument::store::Store;
use instrument::stored::Stored;

/// A block as the DMA leaves it.
pub struct Block {
    /// `[voltage, current]` ADC pairs.
    pub pairs: [[i16; 2]; BLOCK_PAIRS],
    /// A sample hit an ADC rail.
    pub clipped: bool,
    /// The slot it completes (channel, frequency played).
    pub slot: Slot,
}

/// What the command line asks for.
struct Args {
    scenario: Scenario,
    /// The wiring to de-embed.
    fixture: Fixture,
    /// The line model's tab-lead ratio.
    lead_ratio: f32,
    /// `flash=PATH` and `save`.
    flash: FlashArgs,
}

/// The scenario (first argument), the wiring calibration and the tab-lead
/// ratio of the line model (optional further arguments: `id=value` of the
/// catalogue's static effects, SI; without `lead_resistance`, the ratio
/// installed for the scenario's sensor); `flash=PATH` keeps the settings'
/// flash in a host file, and `save` stores the settings of this run there.
fn arguments() -> Args {
    qemu::with_args(|args| {
        let name = args.next().unwrap_or("paper20");
        let scenario = Scenario::parse(name).unwrap_or_else(|| {
            defmt::println!("unknown scenario {=str}", name);
            qemu::exit(2)
        });
        let mut effects = EffectSet::NONE;
        let mut flash = FlashArgs::default();
        for arg in args {
            if flash.take(arg) {
                continue;
            }
            match effects.apply(arg) {
                Ok(e) if e.is_static() => {}
                Ok(_) => {
                    defmt::println!("'{=str}': not a static effect of the sensor", arg);
                    qemu::exit(2)
                }
                Err(err) => {
                    defmt::println!("bad effect '{=str}': {}", arg, defmt::Display2Format(&err));
                    qemu::exit(2)
                }
            }
        }
        let lead_ratio = match effects.get(Effect::LeadResistance) > 0.0 {
            true => effects.lead_ratio(),
            false => scenario.lead_ratio(),
        };
        Args {
            scenario,
            fixture: effects.fixture(),
            lead_ratio,
            flash,
        }
    })
}

/// The sensors as the command line describes them, as a stored set (the
/// test rig knows its simulated sensor, as a calibration run would).
fn rig_set(scenario: &Scenario, fixture: Fixture, lead_ratio: f32) -> Stored {
    let Ok(rig) = Sensor::calibrated(*scenario.calibration(), lead_ratio, fixture) else {
        defmt::println!("tab-lead ratio {=f32} beyond the line model's range", lead_ratio);
        qemu::exit(2)
    };
    Stored::of_sensors(
        &Sensors::<POINTS, 1>::all(rig),
        &Policy::DEFAULT,
        SENSOR_R_REST_OHM as f32,
        CHANNELS,
    )
}

/// The start line: the channels, the scenario, and the first sensor's
/// wiring, tab leads and stretch table.
fn print_start(scenario: &Scenario, settings: &Settings<'_, POINTS, CHANNELS>) {
    let zero = settings.sensors.of(0);
    defmt::println!(
        "start {=u8} channels, scenario {}, wiring calibration {=f32} pF {=f32} ohm, tab-lead ratio {=f32}, stretch calibrated {=bool}",
        CHANNELS as u8,
        defmt::Debug2Format(scenario),
        zero.fixture.parallel_farad * 1e12,
        zero.fixture.series_ohm,
        zero.tracker.inverter().lead_ratio(),
        zero.calibrated
    );
}

#[rtic::app(device = lm3s6965, dispatchers = [SSI0])]
mod app {
    use super::*;
    use lm3s6965::Interrupt;

    #[shared]
    struct Shared {
        block: Block,
        reader: MuxReader,
        done: bool,
        /// How the CPU keeps up: slots' times, late and missed ones.
        busy: Busy,
    }

    #[local]
    struct Local {
        skin: Skin,
        mux: Mux<SimPin, MUX_ADDRESS_LINES>,
        ranges: Mux<SimPin, RANGE_ADDRESS_LINES>,
        scenario: Scenario,
        seq: Sequencer,
        in_force: InForce<Common, CHANNELS>,
        end_slot: u64,
        link: LinkSender,
        store: Option<Store<FileFlash>>,
        commands: Commands,
    }

    #[init(local = [
        // Eight sensors' lines and tables (5 KiB), built in place.
        sensors: MaybeUninit<Sensors<POINTS, CHANNELS>> = MaybeUninit::uninit(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        firmware::stack::paint();
        qemu::Instructions::start(cx.core.SYST);
        let Args {
            scenario,
            fixture,
            lead_ratio,
            flash,
        } = arguments();
        let skin = Skin::new(scenario);
        let (store, (generation, set)) = flash.set_in_force(&rig_set(&scenario, fixture, lead_ratio));
        let Ok(sensors) = firmware::settings_log::sensors_in(cx.local.sensors, &set) else {
            defmt::println!("settings: a tab-lead ratio beyond the line model's range");
            qemu::exit(2)
        };
        let common = Common {
            policy: set.policy,
            record_every: set.record_every,
            ..Settings::new(
                skin.ranging().front_ends(skin.front_end().v_gain as f32),
                skin.ranging(),
                &*sensors,
            )
            .common()
        };
        let in_force = InForce::new(common, sensors, generation);
        let reader = MuxReader::with(|c| {
            let rest = in_force.sensors().of(c).rest_farad;
            match scenario.pinned(c as usize) {
                Some(i) => Channel::pinned(rest, i),
                None => Channel::new(rest),
            }
        });
        // As on the board: slots 0 and 1 are planned, slot 0's channel
        // selected; the simulated DMA then completes one slot per pend.
        let (seq, first) = Sequencer::start(|c| reader.plan(c));
        let mut mux = Mux::new(mux_pins());
        let Ok(_) = mux.select(first[0].channel);
        let mut ranges = Mux::new(range_pins());
        let Ok(_) = ranges.select(first[0].range);
        print_start(&scenario, &in_force.settings());
        (
            Shared {
                block: Block {
                    pairs: [[0; 2]; BLOCK_PAIRS],
                    clipped: false,
                    slot: first[0],
                },
                reader,
                done: false,
                busy: Busy::new(
                    link::Clock::Instructions,
                    instrument::design::SYSCLK_HZ,
                    SLOT_US,
                    SLOTS_PER_S,
                ),
            },
            Local {
                skin,
                mux,
                ranges,
                scenario,
                seq,
                store,
                commands: Commands::new(),
                link: LinkSender::start(
                    Uart0::take(),
                    in_force.start_frame(
                        concat!("skin-qemu ", env!("CARGO_PKG_VERSION")),
                        flash.device,
                        CHANNELS,
                        instrument::design::SAMPLE_RATE,
                    ),
                ),
                in_force,
                end_slot: flash.end_step((scenario.duration_s() * 1e6) as u64 / pairs_us(SLOT_PAIRS)),
            },
        )
    }

    #[idle(shared = [done])]
    fn idle(mut cx: idle::Context) -> ! {
        loop {
            if cx.shared.done.lock(|d| *d) {
                qemu::end();
            }
            rtic::pend(Interrupt::GPIOA);
        }
    }

    /// DMA complete: the simulated front end filled the slot that ends now
    /// (the channel the multiplexer selects, at the frequency the sequencer
    /// prepared for it), as the board's DMA half-transfer would.
    #[task(binds = GPIOA, priority = 2, shared = [block, reader, busy], local = [skin, mux, ranges, scenario, seq])]
    fn dma_done(mut cx: dma_done::Context) {
        let step = {
            let seq = &mut *cx.local.seq;
            cx.shared.reader.lock(|r| seq.complete(|ch| r.plan(ch)))
        };
        let done = step.done;
        if done.index == 10 {
            match cx.local.scenario {
                Scenario::Panic => panic!("injected panic at block {}", done.index),
                Scenario::Hang => loop {
                    cortex_m::asm::nop();
                },
                _ => {}
            }
        }
        let t_us = done.block_mid_us();
        let skin = &mut *cx.local.skin;
        let (ch, truth) = cx.shared.block.lock(|b| {
            let (ch, clipped, truth) = skin.block(done.fidx, t_us, &mut b.pairs);
            b.clipped = clipped;
            b.slot = Slot { channel: ch, ..done };
            (ch, truth)
        });
        // The slot that begins now: its channel settles in its first pairs.
        let Ok(_) = cx.local.mux.select(step.select);
        let Ok(_) = cx.local.ranges.select(step.select_range);
        let truth = truth.line(t_us, ch);
        defmt::println!("{}", truth);
        if process::spawn().is_err() {
            defmt::println!("overrun {=u64}", done.index);
            cx.shared.busy.lock(Busy::missed);
        }
    }

    /// Demodulate, correct and log one block; then the requests the host
    /// sent down the link, answered there.
    #[task(priority = 1, shared = [block, reader, done, busy], local = [in_force, end_slot, link, store, commands])]
    async fn process(mut cx: process::Context) {
        let started = qemu::Instructions::now();
        let local = cx.local;
        // Stopped (by request, or at the scenario's end): the end frame
        // is sent, nothing more is.
        if cx.shared.done.lock(|d| *d) {
            return;
        }
        let (ph, clipped, slot) = cx
            .shared
            .block
            .lock(|b| (instrument::config::read(b.slot.fidx, &b.pairs), b.clipped, b.slot));
        let settings = local.in_force.settings();
        let read = cx.shared.reader.lock(|r| r.read(&settings, &slot, &ph, clipped));
        let spent = qemu::Instructions::since(started);
        let t_us = slot.block_mid_us();
        let (late, status) = cx.shared.busy.lock(|b| (b.block(spent), b.due(t_us)));
        if let Some(s) = status {
            local.link.status(&s);
        }
        match read {
            Read::Report(mut rec) => {
                if late {
                    rec.flags.set(instrument::faults::Flags::LATE);
                }
                defmt::println!("{}", rec);
                local.link.record(frames::from_record(&rec));
            }
            Read::Quiet => {}
            Read::Skipped => defmt::println!("skip {=u64} {=u8}", slot.block_mid_us(), slot.channel),
        }
        let asked = qemu_flash::answer(local.link, local.commands, local.store.as_mut());
        if let (true, Some(store)) = (asked.apply, local.store.as_mut()) {
            // In force from the next block: the frame says so before its
            // record.
            qemu_flash::apply(local.in_force, store, local.link, t_us);
        }
        if asked.stop || slot.index + 1 >= *local.end_slot {
            local.link.end(0);
            cx.shared.done.lock(|d| *d = true);
        }
    }
}
