//! The sensing-skin firmware on QEMU's lm3s6965evb (Cortex-M4), with the
//! simulated front end of [`firmware::scenario`] in place of the board's
//! multiplexer, DAC and ADC/DMA.
//!
//! * `dma_done` (hardware task, bound to the GPIOA interrupt, pended by
//!   `idle` with `rtic::pend` as the board's DMA-complete interrupt would
//!   fire): the block for the selected channel and frequency is ready.
//! * `process` (software task): demodulate, correct, check faults, update
//!   the frequency policy, pick the next channel (round robin), log the
//!   record with defmt.
//!
//! Records (defmt over semihosting, decoded on the host):
//! `rec t_ms channel freq_hz cs_pF rs_ohm c_pF r_ohm stretch_mm flags`, and
//! in QEMU also `truth t_ms channel c_pF r_ohm stretch_mm r_top_ohm
//! r_bottom_ohm` (the rig's view: end-to-end electrode resistances).
//! The scenario is the first semihosting argument (`-semihosting-config
//! enable=on,arg=paper20`); the optional further ones are the static
//! effects `host-sim identify` found, as `id=value` in SI units
//! (`<id>=1.2e-11`, ids from [`instrument::effects`]): the firmware de-embeds the wiring
//! they describe ([`instrument::effects::EffectSet::fixture`]).
#![no_std]
#![no_main]

use dsp_core::fixture::Fixture;
use firmware::qemu;
use firmware::scenario::{mux_pins, Scenario, SimPin, Skin};
use instrument::calib::{CalTable, REFERENCE};
use instrument::channel::{Channel, Settings};
use instrument::config::{BLOCK, CHANNELS, DEMODULATORS, SLOT_S};
use instrument::effects::EffectSet;
use instrument::faults::Thresholds;
use instrument::mux::Mux;
use instrument::policy::Policy;

/// A block as the DMA leaves it.
pub struct Block {
    /// `[voltage, current]` ADC pairs.
    pub pairs: [[i16; 2]; BLOCK],
    /// A sample hit an ADC rail.
    pub clipped: bool,
    /// Channel the multiplexer selected.
    pub channel: u8,
    /// Frequency index the DAC played.
    pub fidx: usize,
    /// Start time of the block, s.
    pub t_s: f32,
}

/// The scenario (first argument) and the wiring calibration (optional
/// further arguments: `id=value` of the catalogue's static effects, SI).
fn arguments() -> (Scenario, Fixture) {
    let Ok(args) = semihosting::experimental::env::args::<128>() else {
        return (Scenario::Paper20, Fixture::NONE);
    };
    let mut it = &args;
    let name = it.next().and_then(Result::ok).unwrap_or("paper20");
    let scenario = Scenario::parse(name).unwrap_or_else(|| {
        defmt::println!("unknown scenario {=str}", name);
        qemu::exit(2)
    });
    let mut effects = EffectSet::NONE;
    for arg in it {
        let Ok(arg) = arg else { qemu::exit(2) };
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
    (scenario, effects.fixture())
}

#[rtic::app(device = lm3s6965, dispatchers = [SSI0])]
mod app {
    use super::*;
    use lm3s6965::Interrupt;

    #[shared]
    struct Shared {
        block: Block,
        /// (channel, frequency index) of the next block.
        next: (u8, usize),
        done: bool,
    }

    #[local]
    struct Local {
        skin: Skin,
        mux: Mux<SimPin, 3>,
        scenario: Scenario,
        channels: [Channel; CHANNELS],
        settings: Settings<'static, 11>,
        end_slot: u32,
    }

    #[init]
    fn init(_: init::Context) -> (Shared, Local) {
        let (scenario, fixture) = arguments();
        let skin = Skin::new(scenario);
        let cal: &'static CalTable<11> = &REFERENCE;
        let settings = Settings {
            policy: Policy::DEFAULT,
            thresholds: Thresholds::DEFAULT,
            front_end: skin.front_end().dsp_front_end(),
            calibration: cal,
            tracker: instrument::channel::tracker(),
            fixture,
        };
        let channels: [Channel; CHANNELS] = core::array::from_fn(|ch| match scenario.pinned(ch) {
            Some(i) => Channel::pinned(cal.rest_capacitance(), i),
            None => Channel::new(cal.rest_capacitance()),
        });
        let fidx = channels[0].freq_index();
        defmt::println!(
            "start {=u8} channels, scenario {}, wiring calibration {=f32} pF {=f32} ohm",
            CHANNELS as u8,
            defmt::Debug2Format(&scenario),
            fixture.parallel_farad * 1e12,
            fixture.series_ohm
        );
        (
            Shared {
                block: Block {
                    pairs: [[0; 2]; BLOCK],
                    clipped: false,
                    channel: 0,
                    fidx,
                    t_s: 0.0,
                },
                next: (0, fidx),
                done: false,
            },
            Local {
                skin,
                mux: Mux::new(mux_pins()),
                scenario,
                channels,
                settings,
                end_slot: (scenario.duration_s() / SLOT_S) as u32,
            },
        )
    }

    #[idle(shared = [done])]
    fn idle(mut cx: idle::Context) -> ! {
        loop {
            if cx.shared.done.lock(|d| *d) {
                defmt::println!("end");
                qemu::exit(0);
            }
            rtic::pend(Interrupt::GPIOA);
        }
    }

    /// DMA complete: the simulated front end filled a block.
    #[task(binds = GPIOA, priority = 2, shared = [block, next], local = [skin, mux, scenario, slot: u32 = 0])]
    fn dma_done(mut cx: dma_done::Context) {
        let slot = *cx.local.slot;
        *cx.local.slot += 1;
        if slot == 10 {
            match cx.local.scenario {
                Scenario::Panic => panic!("injected panic at block {}", slot),
                Scenario::Hang => loop {
                    cortex_m::asm::nop();
                },
                _ => {}
            }
        }
        let (ch, fidx) = cx.shared.next.lock(|n| *n);
        let t_s = slot as f32 * SLOT_S;
        // Select the channel; the slot's first SETTLE_PAIRS pairs let the
        // analog path settle (discarded by the DMA layout on the board).
        let Ok(_) = cx.local.mux.select(ch);
        let skin = cx.local.skin;
        let (ch, truth) = cx.shared.block.lock(|b| {
            let (ch, clipped, truth) = skin.block(fidx, t_s, &mut b.pairs);
            b.clipped = clipped;
            b.channel = ch;
            b.fidx = fidx;
            b.t_s = t_s;
            (ch, truth)
        });
        defmt::println!(
            "truth {=u32} {=u8} {=f32} {=f32} {=f32} {=f32} {=f32}",
            (t_s * 1000.0) as u32,
            ch,
            (truth.c_farad * 1e12) as f32,
            truth.r_line_ohm as f32,
            truth.stretch_mm as f32,
            truth.r_top_ohm as f32,
            truth.r_bottom_ohm as f32
        );
        if process::spawn(slot).is_err() {
            defmt::println!("overrun {=u32}", slot);
        }
    }

    /// Demodulate, correct and log one block; choose the next one.
    #[task(priority = 1, shared = [block, next, done], local = [channels, settings, end_slot])]
    async fn process(mut cx: process::Context, slot: u32) {
        let local = cx.local;
        let (ph, clipped, ch, fidx, t_s) = cx.shared.block.lock(|b| {
            (
                DEMODULATORS[b.fidx].block(&b.pairs),
                b.clipped,
                b.channel,
                b.fidx,
                b.t_s,
            )
        });
        let channel = &mut local.channels[ch as usize];
        // The policy's frequency for this channel was used for this block.
        debug_assert_eq!(channel.freq_index(), fidx);
        let rec = channel.process(
            local.settings,
            ch,
            t_s + 0.5 * instrument::config::BLOCK_S,
            &ph,
            clipped,
        );
        firmware::log::record(t_s, &rec);
        let next = ((ch as usize + 1) % CHANNELS) as u8;
        let next_fidx = local.channels[next as usize].freq_index();
        cx.shared.next.lock(|n| *n = (next, next_fidx));
        if slot + 1 >= *local.end_slot {
            cx.shared.done.lock(|d| *d = true);
        }
    }
}
