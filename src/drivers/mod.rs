//! Device drivers, generic over `embedded-hal` traits and tested on the host
//! with `embedded-hal-mock`.

pub mod i2c_bus_clear;
pub mod ms5837;
pub mod pump;
