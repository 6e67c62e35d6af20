//! The two analog front ends, each started in the order RM0440 asks for:
//! pins, DMA, DAC, ADCs, then the timers that trigger them all. Each
//! application calls one of these from `init`; what each step writes is
//! in its peripheral's module (and tested there).

#[cfg(target_os = "none")]
use super::excitation::DacRing;
#[cfg(target_os = "none")]
use super::{adc, dac, dma, opamp, pac, pins, scan, timer};
use instrument::array::{Layout, Rows, ADCS, SCAN};
#[cfg(target_os = "none")]
use instrument::array::{DAC_RATE_HZ, RATE_HZ};
use instrument::config::SLOT_PAIRS;

/// The multiplexed board's ADC buffer holds two slots.
pub const SLOTS: usize = 2;

/// The multiplexed board's ADC buffer: two slots of packed (ADC1, ADC2)
/// pairs.
pub type AdcSlots = [u32; SLOTS * SLOT_PAIRS];

/// The array's ADC buffers: every ADC's circular buffer of two blocks
/// (of the longest layout; a shorter one's two blocks are its first
/// rows: [`array_half`]).
pub type AdcBlocks = [[Rows; 2]; ADCS];

/// Results per array ADC buffer in blocks of `layout`: two blocks of
/// [`SCAN`] positions.
pub const fn array_results(layout: &Layout) -> usize {
    2 * layout.instants() * SCAN
}

/// Half `half` (0 or 1) of one ADC's circular buffer in blocks of
/// `layout`: its block's rows.
pub fn array_half<'a>(buf: &'a mut [Rows; 2], layout: &Layout, half: usize) -> &'a mut [[i16; SCAN]] {
    let n = layout.instants();
    let flat = buf.as_flattened_mut();
    let start = (half.min(1) * n).min(flat.len());
    let end = (start + n).min(flat.len());
    &mut flat[start..end]
}

/// DMA1 channel (0-based) whose interrupt paces the array's blocks: the
/// last of the five ADCs the DMA serves.
pub const ARRAY_PACER: usize = ADCS - 1;

/// The multiplexed front end: PA0/PA1 analog, the multiplexer's address
/// lines, DMA1 channels 1 (ADC pairs → `adc_buf`) and 2 (the excitation's
/// ring `dac_ring` → DAC, [`super::excitation`]), the DAC, ADC1 + ADC2 in
/// dual mode, then TIM6, configured but not counting: the application
/// starts it ([`super::timer::start`], TIM6 from
/// [`super::setup::Owned`]) at the end of its `init`, once its tasks can
/// refill the DAC's ring (two quarter slots, 2.7 ms) in time.
#[cfg(target_os = "none")]
pub fn multiplexed(dp: &pac::Peripherals, adc_buf: &AdcSlots, dac_ring: &DacRing) {
    pins::analog(&dp.GPIOA);
    pins::mux_outputs(&dp.GPIOB);
    dma::requests(&dp.DMAMUX);
    dma::adc_channel(
        &dp.DMA1,
        dp.ADC12_COMMON.cdr().as_ptr() as u32,
        adc_buf.as_ptr() as u32,
        adc_buf.len() as u16,
    );
    dma::dac_channel(
        &dp.DMA1,
        dac_ring.as_ptr() as u32,
        dp.DAC1.dhr12r1().as_ptr() as u32,
        dac_ring.len() as u16,
    );
    dac::configure(&dp.DAC1);
    adc::init(dp);
    timer::configure(&dp.TIM6);
}

/// The array's front end in blocks of `layout`: its analog pins, the
/// op-amp followers, DMA1 channels 1–5 (each ADC → its buffer in
/// `adc_bufs`, two blocks round, the pacer with interrupts) and 6
/// (`table`, one block's codes ([`Layout::dac_table`]) → DAC), the DAC
/// on TIM7, the five scanning ADCs, then TIM7 and TIM6, which start them.
#[cfg(target_os = "none")]
pub fn array(dp: &pac::Peripherals, layout: &Layout, adc_bufs: &AdcBlocks, table: &[u16]) {
    pins::array_analog(&dp.GPIOA, &dp.GPIOB, &dp.GPIOC);
    opamp::followers(&dp.OPAMP);
    dma::array_requests(&dp.DMAMUX);
    for (a, adc) in scan::blocks(dp).iter().enumerate() {
        dma::scan_channel(
            &dp.DMA1,
            a,
            adc.dr().as_ptr() as u32,
            adc_bufs[a].as_ptr() as u32,
            array_results(layout) as u16,
            a == ARRAY_PACER,
        );
    }
    dma::table_channel(
        &dp.DMA1,
        table.as_ptr() as u32,
        dp.DAC1.dhr12r1().as_ptr() as u32,
        table.len() as u16,
    );
    dac::configure_array(&dp.DAC1);
    scan::init(dp);
    timer::configure_arr(&dp.TIM7, timer::arr_for(DAC_RATE_HZ));
    timer::configure_arr(&dp.TIM6, timer::arr_for(RATE_HZ));
    timer::start(&dp.TIM7);
    timer::start(&dp.TIM6);
}
