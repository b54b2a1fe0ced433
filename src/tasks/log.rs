//! Logging that is defmt on the board and nothing on the host (the virtual
//! board reports through the host link instead). The arguments are still
//! evaluated by reference on the host, so no variable goes unused.

macro_rules! log_at {
    ($level:ident, $fmt:literal $(, $arg:expr)* $(,)?) => {{
        #[cfg(all(feature = "defmt", target_os = "none"))]
        {
            defmt::$level!($fmt $(, $arg)*);
        }
        #[cfg(not(all(feature = "defmt", target_os = "none")))]
        {
            $(let _ = &$arg;)*
        }
    }};
}

macro_rules! log_info {
    ($($t:tt)*) => { $crate::tasks::log::log_at!(info, $($t)*) };
}

macro_rules! log_warn {
    ($($t:tt)*) => { $crate::tasks::log::log_at!(warn, $($t)*) };
}

macro_rules! log_error {
    ($($t:tt)*) => { $crate::tasks::log::log_at!(error, $($t)*) };
}

pub(crate) use {log_at, log_error, log_info, log_warn};
