#![no_std]
#![no_main]
use core::hint::black_box;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m_rt::entry;
use firmware::qemu;
use lm3s6965 as _;

static MARK: AtomicU32 = AtomicU32::new(0);
#[no_mangle]
#[inline(never)]
pub extern "C" fn prof_mark(n: u32) {
    MARK.store(black_box(n), Ordering::SeqCst);
    unsafe { core::arch::asm!("nop", "nop") };
}

#[entry]
fn main() -> ! {
    use instrument::array::{tones_hz, Frame, BLOCK_INSTANTS, SENSORS};
    use instrument::reader::ArrayReader;
    use instrument::tones::ToneSettings;
    use skin_sim::array::ArrayFrontEnd;
    use skin_sim::frontend::Disturbance;
    use skin_sim::sensor::{Sensor, SensorParams};
    let fe = ArrayFrontEnd::REFERENCE;
    let p = SensorParams::PAPER;
    let cal = skin_sim::sensor::PAPER_CALIBRATION;
    let Ok(paper) =
        instrument::sensor::Sensor::calibrated(cal, p.effects.lead_ratio(), dsp_core::fixture::Fixture::NONE)
    else { qemu::exit(5) };
    let sensors = instrument::sensor::Sensors::all(paper);
    let settings = ToneSettings::new(fe.dsp_front_end(), &sensors);
    let Ok(mut reader) = ArrayReader::new(&sensors) else { qemu::exit(5) };
    let hz = tones_hz().map(|f| f as f64);
    let z = [Sensor::settled(p).impedances(&hz); SENSORS];
    let mut rng = skin_sim::rng::Rng::new(7);
    let mut frame: Frame = [[[0; 4]; BLOCK_INSTANTS]; 5];
    let mut block = reader.demodulate(|a| &frame[a]);
    let mut enc = link::Encoder::new();
    let mut out = [0u8; link::MAX_FRAME];
    for b in 0..2u64 {
        fe.frame(&z, &[Disturbance::NONE; SENSORS], &mut rng, &mut frame);
        block = reader.demodulate(|a| black_box(&frame[a]));
        if b > 0 { prof_mark(1); }
        reader.solve(&settings, b * 4000 + 2000, &block, |_| false, |r| {
            let record = instrument::frames::from_tone_record(black_box(&r));
            black_box(enc.record(&record, black_box(&mut out)).map_or(0, <[u8]>::len));
        });
        if b > 0 { prof_mark(0); }
    }
    qemu::exit(0)
}
