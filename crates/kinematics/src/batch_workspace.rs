//! What a mechanism keeps from one batch of contacts to the next:
//! [`BatchWorkspace`].

use std::any::Any;
use std::fmt;

/// The working memory a caller hands a mechanism's batches
/// ([`Mechanism::tool_points_at_readings`], [`Mechanism::tool_points_along`])
/// one after another, where the mechanism keeps what they share: what it
/// derives from the parameters (the hexapod's canonical geometry, made
/// again only for other parameters) and what one batch leaves the next
/// (the row order its factorisations try first, on which only the last
/// bits of a result depend). Empty until a mechanism fills it; one
/// workspace serves one mechanism. A caller whose results must not depend
/// on the number of threads makes one per fixed piece of work (a solver's
/// chunk of one pass), as it does its other working memory.
///
/// [`Mechanism::tool_points_at_readings`]: crate::mechanism::Mechanism::tool_points_at_readings
/// [`Mechanism::tool_points_along`]: crate::mechanism::Mechanism::tool_points_along
#[derive(Default)]
pub struct BatchWorkspace(Option<Box<dyn Any + Send>>);

impl BatchWorkspace {
    /// The `T` it holds, made by `fresh` first when it holds none (or
    /// another type's).
    pub fn held<T: Any + Send>(&mut self, fresh: impl FnOnce() -> T) -> &mut T {
        if !self.0.as_ref().is_some_and(|held| held.is::<T>()) {
            self.0 = Some(Box::new(fresh()));
        }
        (self.0.as_mut())
            .and_then(|held| held.downcast_mut())
            .expect("a T is held: it was just put there if not")
    }
}

impl fmt::Debug for BatchWorkspace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let state = if self.0.is_some() { "held" } else { "empty" };
        write!(f, "BatchWorkspace({state})")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn it_keeps_what_was_put_until_another_type_is_asked_for() {
        let mut workspace = BatchWorkspace::default();
        assert_eq!(format!("{workspace:?}"), "BatchWorkspace(empty)");
        *workspace.held(|| 1_u32) += 1;
        assert_eq!(*workspace.held(|| 10_u32), 2);
        assert_eq!(workspace.held(|| 5.0_f64), &5.0);
        assert_eq!(*workspace.held(|| 10_u32), 10);
        assert_eq!(format!("{workspace:?}"), "BatchWorkspace(held)");
    }
}
