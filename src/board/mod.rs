//! The embassy glue for the NUCLEO-F446RE: one task per role, talking only
//! through the `embassy_sync` primitives in [`channels`]. Every decision is
//! made by [`crate::controller::Controller::step`]; the tasks here only move
//! data between it and the pins.
//!
//! | task | owns | publishes | reads |
//! |---|---|---|---|
//! | [`sensor::sensor_task`] | I²C1 + MS5837 | [`channels::SAMPLE`] (latest wins) | — |
//! | [`control::control_task`] | controller, relief valve, advance drive, IWDG | [`channels::PUMP_COMMAND`], [`channels::TELEMETRY`], [`channels::REPLIES`] | sample, pump status, [`channels::REQUESTS`] |
//! | [`pump::pump_task`] | STEP/DIR/ENABLE, end-stops | [`channels::PUMP_STATUS`] (latest wins) | pump command |
//! | [`link::rx_task`] | USART2 RX (DMA ring) | [`channels::REQUESTS`], `Pong`/`Nack` replies | — |
//! | [`link::tx_task`] | USART2 TX (DMA) | frames on the wire | replies, telemetry |
//!
//! # Wiring (NUCLEO-F446RE, Arduino header names in brackets)
//!
//! | signal | pin | notes |
//! |---|---|---|
//! | I²C1 SCL | PB8 (D15) | MS5837 SCL; 100 kHz, external 4.7 kΩ pull-ups to 3.3 V |
//! | I²C1 SDA | PB9 (D14) | MS5837 SDA |
//! | STEP | PA10 (D2) | stepper driver STEP (A4988/DRV8825), idles low |
//! | DIR | PB3 (D3) | stepper driver DIR (PB3 is SWO: leave SWO trace off) |
//! | ENABLE | PB5 (D4) | stepper driver EN, active low; boots high (off). Fit a 10 kΩ pull-up so the driver also stays off while the MCU is in reset |
//! | end-stop EMPTY | PB4 (D5) | switch to GND, internal pull-up, closed = low (plunger fully in) |
//! | end-stop FULL | PB10 (D6) | switch to GND, internal pull-up, closed = low (plunger fully out) |
//! | relief valve | PA8 (D7) | through a MOSFET to a normally-open valve: high = energised = closed; reset or fault vents |
//! | advance drive | PA9 (D8) | high = external advance drive on |
//! | USART2 TX | PA2 | ST-LINK virtual COM port, 115200 8N1 |
//! | USART2 RX | PA3 | ST-LINK virtual COM port |
//!
//! Sensor and pump grounds go to the NUCLEO's GND; the stepper driver's motor
//! supply is separate. Clocks: HSI 16 MHz → PLL → 84 MHz SYSCLK (APB1 42 MHz,
//! APB2 84 MHz), so no solder-bridge change is needed for an external clock.

pub mod busy_wait;
pub mod channels;
pub mod control;
pub mod link;
pub mod pump;
pub mod sensor;

/// Milliseconds since boot on the embassy clock, truncated to `u32` (wraps
/// after 49 days; the controller takes all differences wrapping).
pub fn now_ms() -> u32 {
    // Truncation is the documented wrap of `Inputs::now_ms`.
    embassy_time::Instant::now().as_millis() as u32
}
