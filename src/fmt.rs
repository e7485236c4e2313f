//! Internal logging macros: defmt with the `defmt` feature, nothing without.
//!
//! Core code calls `debug!` from here, never `defmt` directly, so host tests need no logger and
//! the firmware decides what is printed. Without the feature the arguments are only borrowed, so
//! no variable turns "unused".
#![allow(unused_macros)]

macro_rules! debug {
    ($s:literal $(, $x:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        ::defmt::debug!($s $(, $x)*);
        #[cfg(not(feature = "defmt"))]
        let _ = ($( & $x ),*);
    }};
}
