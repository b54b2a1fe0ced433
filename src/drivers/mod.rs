//! Device drivers, generic over `embedded-hal` traits and tested on the host
//! with `embedded-hal-mock`.
