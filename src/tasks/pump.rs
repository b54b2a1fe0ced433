//! The pump task: turns the latest [`PumpCommand`] into STEP pulses at the
//! commanded rate, ramped, and reports the plunger's volume and end-stops.
//! The pulses are timed by the executor (one wake-up per microstep, 2 µs
//! busy-waited pulses), not by a hardware timer.

use embassy_futures::select::{select, Either};
use embassy_time::{Duration, Instant, Timer};
use embedded_hal::digital::{InputPin, OutputPin};

use super::busy_wait::BusyWait;
use super::log::{log_error, log_warn};
use super::{PumpStatus, Shared};
use crate::controller::{EndStops, PumpCommand};
use crate::drivers::pump::{Direction, EndStopDebounce, Plan, PumpError, StepPlanner, SyringePump};

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
/// trapezoidal [`StepPlanner`] (rate changes at most
/// [`ACCEL_ML_PER_S2`](crate::drivers::pump::ACCEL_ML_PER_S2), every
/// reversal through a stop).
///
/// - `Disable`: ENABLE off, no steps, the planner stopped at once (the
///   boot state; the fault state).
/// - `Hold`: ENABLE on, the rate ramps down to rest (at most 0.04 mL
///   further, from 4 mL/s), then no steps.
/// - `Run`: ENABLE on, the rate ramps to the command's (clamped to
///   [`MAX_RATE_ML_PER_S`](crate::drivers::pump::MAX_RATE_ML_PER_S)); each
///   microstep on its planned deadline after the previous one (no drift
///   from the pulse's own length). A new command re-targets the planner
///   from the next step on. The driver refuses a step into a triggered
///   end-stop (raw reading), and the planner restarts from standstill.
///
/// After every change and every step it publishes [`Shared::pump_status`].
pub async fn run<S, D, E, Ee, Ef>(mut pump: SyringePump<S, D, E, Ee, Ef>, shared: &Shared) -> !
where
    S: OutputPin,
    D: OutputPin,
    E: OutputPin,
    Ee: InputPin,
    Ef: InputPin,
{
    let mut command = PumpCommand::Disable;
    let mut debounce = EndStopDebounce::new();
    let mut planner = StepPlanner::new(pump.config().ml_per_step());
    apply(&mut pump, command);
    publish(&mut pump, &mut debounce, shared);
    let mut last_step = Instant::now();
    let mut pending: Option<(Direction, Instant)> = None;
    // Logged once per change, not at the step rate.
    let mut last_refusal: Option<PumpError> = None;
    loop {
        if pending.is_none() && command != PumpCommand::Disable {
            let target = match command {
                PumpCommand::Run { rate_ml_per_s } => rate_ml_per_s,
                PumpCommand::Disable | PumpCommand::Hold => 0.0,
            };
            let from_rest = planner.rate_ml_per_s() == 0.0;
            if let Plan::Step { direction, wait_us } = planner.next(target) {
                let base = if from_rest { Instant::now() } else { last_step };
                pending = Some((direction, base + Duration::from_micros(u64::from(wait_us))));
            }
        }
        let wake_at = match pending {
            Some((_, at)) => at,
            None => Instant::now() + Duration::from_millis(IDLE_POLL_MS),
        };
        match select(shared.pump_command.wait(), Timer::at(wake_at)).await {
            Either::First(new) => {
                command = new;
                if command == PumpCommand::Disable {
                    planner.stop_now();
                    pending = None;
                }
                apply(&mut pump, command);
            }
            Either::Second(()) => {
                if let Some((direction, at)) = pending.take() {
                    // On a refusal (end-stop, disabled) no step was made;
                    // the controller sees the end-stop and decides.
                    let refusal = pump.step(direction, &mut BusyWait).await.err();
                    if refusal.is_some() {
                        planner.stop_now();
                    }
                    if refusal != last_refusal {
                        if let Some(e) = refusal {
                            log_warn!("pump: step refused: {}", e);
                        }
                        last_refusal = refusal;
                    }
                    // After a stall of the executor, do not burst to
                    // catch up.
                    let now = Instant::now();
                    last_step = if at < now { now } else { at };
                }
            }
        }
        publish(&mut pump, &mut debounce, shared);
    }
}

/// ENABLE per command. A failed pin write leaves the driver refusing steps.
fn apply<S, D, E, Ee, Ef>(pump: &mut SyringePump<S, D, E, Ee, Ef>, command: PumpCommand)
where
    S: OutputPin,
    D: OutputPin,
    E: OutputPin,
    Ee: InputPin,
    Ef: InputPin,
{
    let result = match command {
        PumpCommand::Disable => pump.disable(),
        PumpCommand::Hold | PumpCommand::Run { .. } => pump.enable(),
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
    S: OutputPin,
    D: OutputPin,
    E: OutputPin,
    Ee: InputPin,
    Ef: InputPin,
{
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
