//! Choices named on the command line and in Python (export formats).

/// The choice named `name` in `names`, if any.
pub(crate) fn by_name<T: Copy>(names: &[(&'static str, T)], name: &str) -> Option<T> {
    names
        .iter()
        .find(|(known, _)| *known == name)
        .map(|&(_, choice)| choice)
}

/// The name of `choice` in `names` (`""` if it has none).
pub(crate) fn name_of<T: PartialEq>(names: &[(&'static str, T)], choice: &T) -> &'static str {
    names
        .iter()
        .find(|(_, known)| known == choice)
        .map_or("", |(name, _)| name)
}
