//! STEP from TIM1 channel 3 on PA10 (AF1): the board's [`StepPulses`].
//!
//! TIM1 counts down at 1 MHz (PSC 83 from the 84 MHz APB2 timer clock) in
//! PWM mode 1, so CH3 is low while `CNT > CCR3` and high from
//! `CNT = CCR3` down to 0: a rising edge `ARR − CCR3` ticks after each
//! reload and a pulse of `CCR3 + 1` = [`STEP_HIGH_US`] ticks that ends at
//! the underflow (RM0390 §17.3.10). The auto-reload is preloaded (ARPE):
//! a period written now takes effect at the next update event, so
//! consecutive edges lie exactly `ARR + 1` ticks apart and the executor
//! only has to write each period within the period before it. The update
//! interrupt counts completed pulses; one-pulse mode (OPM) ends a run at
//! the next update, with STEP already low. Updates from the UG bit do not
//! interrupt (URS), so only real pulses count.
//!
//! Not run on hardware: the register sequence follows the reference
//! manual and is checked only by the host model of the same timer
//! ([`crate::drivers::pump::SimStepTimer`]).

use core::future::poll_fn;
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Poll;

use embassy_stm32::gpio::OutputType;
use embassy_stm32::interrupt::typelevel::{Binding, Handler, Interrupt};
use embassy_stm32::pac::timer::vals::{Dir, Ocm, Urs};
use embassy_stm32::peripherals::{PA10, TIM1};
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::timer::simple_pwm::PwmPin;
use embassy_stm32::timer::{Ch3, CoreInstance};
use embassy_stm32::{pac, Peri};
use embassy_sync::waitqueue::AtomicWaker;

use crate::drivers::pump::pulses::clamp_period_us;
use crate::drivers::pump::{StepPulses, STEP_HIGH_US};

/// CH3's index in the timer's channel registers.
const CH3: usize = 2;

/// Compare value: the pulse is high for `CCR3 + 1` ticks.
const CCR3: u16 = (STEP_HIGH_US - 1) as u16;

/// Update events since boot (completed pulses), counted by the interrupt.
static UPDATES: AtomicU32 = AtomicU32::new(0);

/// The pump task, waiting for the next pulse.
static WAKER: AtomicWaker = AtomicWaker::new();

/// TIM1's update interrupt: counts a completed pulse and wakes the pump
/// task.
pub struct UpdateInterrupt;

impl Handler<<TIM1 as CoreInstance>::UpdateInterrupt> for UpdateInterrupt {
    unsafe fn on_interrupt() {
        let sr = pac::TIM1.sr();
        if sr.read().uif() {
            sr.modify(|w| w.set_uif(false));
            UPDATES.fetch_add(1, Ordering::Relaxed);
            WAKER.wake();
        }
    }
}

/// Stops TIM1 and forces CH3 low, by register: for
/// [`super::safe::drive_outputs_safe`] (boot, the Fault state, the panic
/// and HardFault handlers), which then drives PA10 low as a GPIO. Writes
/// to TIM1 with its clock off (at boot) are ignored, harmlessly.
pub fn stop_by_register() {
    let t = pac::TIM1;
    t.cr1().modify(|w| w.set_cen(false));
    t.ccmr_output(CH3 / 2)
        .modify(|w| w.set_ocm(CH3 % 2, Ocm::FORCE_INACTIVE));
}

/// TIM1 CH3 on PA10, pulsing STEP.
pub struct StepTimer {
    _timer: Timer<'static, TIM1>,
    _pin: PwmPin<'static, TIM1, Ch3>,
    /// [`UPDATES`] at the last start.
    base: u32,
}

impl StepTimer {
    /// Takes TIM1 and PA10, stopped with STEP low, its update interrupt
    /// enabled.
    pub fn new(
        tim: Peri<'static, TIM1>,
        pin: Peri<'static, PA10>,
        _irq: impl Binding<<TIM1 as CoreInstance>::UpdateInterrupt, UpdateInterrupt>,
    ) -> Self {
        let mut timer = Timer::new(tim);
        // 1 µs ticks (also loads the prescaler with an update event).
        timer.set_tick_freq(Hertz(1_000_000));
        let t = pac::TIM1;
        stop_by_register();
        t.cr1().modify(|w| {
            w.set_dir(Dir::DOWN);
            w.set_arpe(true);
            w.set_urs(Urs::COUNTER_ONLY);
            w.set_opm(false);
        });
        t.ccr(CH3).write(|w| w.set_ccr(CCR3));
        t.ccmr_output(CH3 / 2).modify(|w| w.set_ocpe(CH3 % 2, true));
        t.ccer().modify(|w| {
            w.set_ccp(CH3, false);
            w.set_cce(CH3, true);
        });
        // An advanced timer's outputs need MOE.
        t.bdtr().modify(|w| w.set_moe(true));
        t.sr().write(|w| w.0 = 0);
        t.dier().modify(|w| w.set_uie(true));
        // Push-pull on AF1, low before the timer drives it.
        let pin = PwmPin::new(pin, OutputType::PushPull);
        <TIM1 as CoreInstance>::UpdateInterrupt::unpend();
        // SAFETY: the handler touches only TIM1's status, the counter and
        // the waker.
        unsafe { <TIM1 as CoreInstance>::UpdateInterrupt::enable() };
        Self {
            _timer: timer,
            _pin: pin,
            base: UPDATES.load(Ordering::Relaxed),
        }
    }
}

impl StepPulses for StepTimer {
    fn start(&mut self, first_us: u32, second_us: u32) {
        let t = pac::TIM1;
        // The safe state may have made PA10 a plain output: back to the
        // timer (AF1 was set once and stays).
        pac::GPIOA
            .moder()
            .modify(|w| w.set_moder(10, pac::gpio::vals::Moder::ALTERNATE));
        // First edge `first_us` after the counter starts at ARR.
        let first = clamp_period_us(first_us) as u16 + CCR3;
        t.arr().write(|w| w.set_arr(first));
        // Loads ARR into the counter (URS: no interrupt, no count).
        t.egr().write(|w| w.set_ug(true));
        t.arr()
            .write(|w| w.set_arr((clamp_period_us(second_us) - 1) as u16));
        self.base = UPDATES.load(Ordering::Relaxed);
        // CNT = ARR > CCR3: the output stays low until the first edge.
        t.ccmr_output(CH3 / 2)
            .modify(|w| w.set_ocm(CH3 % 2, Ocm::PWM_MODE1));
        t.cr1().modify(|w| {
            w.set_opm(false);
            w.set_cen(true);
        });
    }

    fn queue_period(&mut self, period_us: u32) {
        pac::TIM1
            .arr()
            .write(|w| w.set_arr((clamp_period_us(period_us) - 1) as u16));
    }

    fn finish(&mut self) {
        // The counter stops at the next underflow: the end of the pulse in
        // progress, STEP low.
        pac::TIM1.cr1().modify(|w| w.set_opm(true));
    }

    fn stop(&mut self) {
        let t = pac::TIM1;
        let was_running = t.cr1().read().cen();
        stop_by_register();
        // Read with the counter stopped: at or below CCR3 the pulse was
        // high and its update will not come (an update just before the
        // stop reloaded the counter above CCR3, and the interrupt counts
        // it).
        if was_running && t.cnt().read().cnt() <= CCR3 {
            // Its edge came: the driver stepped.
            UPDATES.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn pulses(&self) -> u32 {
        UPDATES.load(Ordering::Relaxed).wrapping_sub(self.base)
    }

    fn running(&self) -> bool {
        pac::TIM1.cr1().read().cen()
    }

    async fn wait_pulse(&mut self, seen: u32) {
        poll_fn(|cx| {
            WAKER.register(cx.waker());
            if self.pulses() != seen || !self.running() {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
        .await
    }
}
