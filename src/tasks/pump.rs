//! The pump task: turns the latest [`PumpCommand`] into a step plan for
//! the STEP timer, ramped, and reports the plunger's volume and end-stops.
//! The edges are timed by the timer ([`StepPulses`]); the task only keeps
//! the next period queued, once per completed pulse
//! ([`StepSequencer`]).

use embassy_futures::select::{select3, Either3};
use embassy_time::{Duration, Instant, Timer};
use embedded_hal::digital::{InputPin, OutputPin};

use super::log::{log_error, log_warn};
use super::{PumpStatus, Shared};
use crate::controller::{EndStops, PumpCommand};
use crate::drivers::pump::{EndStopDebounce, PumpError, StepPulses, StepSequencer, SyringePump};

/// How often the end-stops are re-read while the motor is not stepping
/// (ms), so the control loop sees a triggered switch within a step or two.
pub const IDLE_POLL_MS: u64 = 2;

// The end-to-end bounds count on a switch published within the board's
// stated delay: the debounce, then at most one idle poll.
const _: () = assert!(
    crate::drivers::pump::END_STOP_DEBOUNCE_US / 1_000 + IDLE_POLL_MS as u32
        <= crate::controller::BOARD_TIMING.end_stop_delay_ms
);

/// Applies [`Shared::pump_command`]s as they arrive, through a
/// trapezoidal [`StepSequencer`] (rate changes at most
/// [`ACCEL_ML_PER_S2`](crate::drivers::pump::ACCEL_ML_PER_S2), every
/// reversal through a stop, DIR written only with the timer stopped).
///
/// - `Disable`: the timer stopped at once (STEP low), ENABLE off, the plan
///   forgotten (the boot state; the fault state).
/// - `Hold`: ENABLE on, the rate ramps down to rest (at most 0.04 mL
///   further, from 4 mL/s), then the timer stops after the last pulse.
/// - `Run`: ENABLE on, the rate ramps to the command's (clamped to
///   [`MAX_RATE_ML_PER_S`](crate::drivers::pump::MAX_RATE_ML_PER_S)). The
///   timer times every edge; after each completed pulse the task queues
///   the period of the pulse after the next, so a wake-up up to one
///   period late moves no edge. A new command re-targets the plan from
///   the next queued pulse on. A raw end-stop ahead stops the timer at
///   once (at most the pulse in progress still comes), and the plan
///   restarts from standstill.
///
/// After every change and every pulse it publishes [`Shared::pump_status`]:
/// the volume of the pulses the timer completed.
pub async fn run<S, D, E, Ee, Ef>(mut pump: SyringePump<S, D, E, Ee, Ef>, shared: &Shared) -> !
where
    S: StepPulses,
    D: OutputPin,
    E: OutputPin,
    Ee: InputPin,
    Ef: InputPin,
{
    let mut command = PumpCommand::Disable;
    let mut debounce = EndStopDebounce::new();
    let mut sequencer = StepSequencer::new(pump.config().ml_per_step());
    apply(&mut pump, &mut sequencer, command);
    publish(&mut pump, &mut debounce, shared);
    // Logged once per change, not at the step rate.
    let mut last_refusal: Option<PumpError> = None;
    loop {
        let seen = pump.sync();
        let running = pump.running();
        // At rest there is no pulse to wait for (`wait_pulse` would return
        // at once): the command or the idle poll wakes the task.
        let pulse = async {
            if running {
                pump.wait_pulse(seen).await;
            } else {
                core::future::pending::<()>().await;
            }
        };
        let idle = Timer::after(Duration::from_millis(IDLE_POLL_MS));
        match select3(shared.pump_command.wait(), pulse, idle).await {
            Either3::First(new) => {
                command = new;
                apply(&mut pump, &mut sequencer, command);
            }
            Either3::Second(()) | Either3::Third(()) => {}
        }
        if command != PumpCommand::Disable {
            // On a refusal (end-stop, disabled) the timer is stopped; the
            // controller sees the end-stop and decides.
            let refusal = sequencer.service(&mut pump).err();
            if refusal != last_refusal {
                if let Some(e) = refusal {
                    log_warn!("pump: step refused: {}", e);
                }
                last_refusal = refusal;
            }
        }
        publish(&mut pump, &mut debounce, shared);
    }
}

/// The target and ENABLE per command; `Disable` stops the timer first. A
/// failed pin write leaves the driver refusing to start.
fn apply<S, D, E, Ee, Ef>(
    pump: &mut SyringePump<S, D, E, Ee, Ef>,
    sequencer: &mut StepSequencer,
    command: PumpCommand,
) where
    S: StepPulses,
    D: OutputPin,
    E: OutputPin,
    Ee: InputPin,
    Ef: InputPin,
{
    let result = match command {
        PumpCommand::Disable => {
            sequencer.stop_now();
            sequencer.set_target(0.0);
            pump.disable()
        }
        PumpCommand::Hold => {
            sequencer.set_target(0.0);
            pump.enable()
        }
        PumpCommand::Run { rate_ml_per_s } => {
            sequencer.set_target(rate_ml_per_s);
            pump.enable()
        }
    };
    if let Err(e) = result {
        log_error!("pump: {} failed: {}", command, e);
    }
}

/// Publishes volume and debounced end-stops ([`EndStopDebounce`]); an
/// unreadable switch reads as triggered so the controller stops.
fn publish<S, D, E, Ee, Ef>(
    pump: &mut SyringePump<S, D, E, Ee, Ef>,
    debounce: &mut EndStopDebounce,
    shared: &Shared,
) where
    S: StepPulses,
    D: OutputPin,
    E: OutputPin,
    Ee: InputPin,
    Ef: InputPin,
{
    pump.sync();
    let raw = pump.end_stops().unwrap_or(EndStops {
        empty: true,
        full: true,
    });
    // The µs clock wraps after 71 minutes; the debounce takes differences.
    let end_stops = debounce.update(raw, Instant::now().as_micros() as u32);
    shared.pump_status.sender().send(PumpStatus {
        volume_ml: pump.volume_ml(),
        end_stops,
    });
}
