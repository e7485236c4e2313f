//! Where the application's link side lives: behind a lock the platform provides.
//!
//! The application holds its [`Session`](super::Session) through [`Shared`] rather than
//! owning it, so that a controller can serve the link from an interrupt while the
//! application's loop plans a slice or builds a layer (seconds of work that take no byte
//! from the line). On the host a [`RefCell`] is the lock; a controller wraps the session
//! in a critical-section mutex in a `static` and serves it from its receive interrupt. The
//! lock is held only for a call into the session, never across planning or stepping.

use core::cell::RefCell;

/// A value behind a lock: [`lock`](Shared::lock) runs `f` on it with the lock held.
/// `f` must not take the lock again (a [`RefCell`] panics, a critical section nests).
pub trait Shared<T> {
    /// Runs `f` on the value, the lock held.
    fn lock<R>(&self, f: impl FnOnce(&mut T) -> R) -> R;
}

impl<T> Shared<T> for RefCell<T> {
    fn lock<R>(&self, f: impl FnOnce(&mut T) -> R) -> R {
        f(&mut self.borrow_mut())
    }
}
