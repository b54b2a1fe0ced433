//! The pump task: turns the latest [`PumpCommand`] into STEP pulses at the
//! commanded rate and reports the plunger's volume and end-stops.

use embassy_futures::select::{select, Either};
use embassy_time::{Duration, Instant, Timer};
use embedded_hal::digital::{InputPin, OutputPin};

use super::busy_wait::BusyWait;
use super::log::{log_error, log_warn};
use super::{PumpStatus, Shared};
use crate::controller::{EndStops, PumpCommand};
use crate::drivers::pump::{Direction, EndStopDebounce, PumpError, SyringePump};

/// How often the end-stops are re-read while the motor is not stepping
/// (ms), so the control loop sees a triggered switch within a step or two.
pub const IDLE_POLL_MS: u64 = 2;

/// Applies [`Shared::pump_command`]s as they arrive.
///
/// - `Disable`: ENABLE off, no steps (the boot state).
/// - `Hold`: ENABLE on, no steps.
/// - `Run`: ENABLE on, one microstep every
///   [`crate::drivers::pump::PumpConfig::step_interval_us`] on deadlines
///   (no drift from the pulse's own length); a new command cancels the
///   wait at once. The driver refuses a step into a triggered end-stop
///   (raw reading).
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
    apply(&mut pump, command);
    publish(&mut pump, &mut debounce, shared);
    let mut next_step = Instant::now();
    // Logged once per change, not at the step rate.
    let mut last_refusal: Option<PumpError> = None;
    loop {
        let motion = match command {
            PumpCommand::Run { rate_ml_per_s } => Direction::from_rate(rate_ml_per_s)
                .zip(pump.config().step_interval_us(rate_ml_per_s))
                .map(|(dir, us)| (dir, Duration::from_micros(u64::from(us)))),
            PumpCommand::Disable | PumpCommand::Hold => None,
        };
        let wake_at = match motion {
            Some(_) => next_step,
            None => Instant::now() + Duration::from_millis(IDLE_POLL_MS),
        };
        match select(shared.pump_command.wait(), Timer::at(wake_at)).await {
            Either::First(new) => {
                if !same_motion(command, new) {
                    // A start or reversal steps at once, then on the new period.
                    next_step = Instant::now();
                }
                command = new;
                apply(&mut pump, command);
            }
            Either::Second(()) => {
                if let Some((direction, interval)) = motion {
                    // On a refusal (end-stop, disabled) no step was made;
                    // the controller sees the end-stop and decides.
                    let refusal = pump.step(direction, &mut BusyWait).await.err();
                    if refusal != last_refusal {
                        if let Some(e) = refusal {
                            log_warn!("pump: step refused: {}", e);
                        }
                        last_refusal = refusal;
                    }
                    next_step += interval;
                    // After a stall of the executor, do not burst to catch up.
                    let now = Instant::now();
                    if next_step < now {
                        next_step = now;
                    }
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

/// True when `new` keeps stepping the same way as `old` (only the rate may
/// differ): the step schedule then continues.
fn same_motion(old: PumpCommand, new: PumpCommand) -> bool {
    match (old, new) {
        (PumpCommand::Run { rate_ml_per_s: a }, PumpCommand::Run { rate_ml_per_s: b }) => {
            Direction::from_rate(a).is_some() && Direction::from_rate(a) == Direction::from_rate(b)
        }
        _ => false,
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
