//! The rows of a row-major block, front to back, for the kernels' loops.
//!
//! `chunks_exact(n)` counts its chunks with an integer division each time
//! it is made, and the kernels make one for every column a reflector or a
//! tile passes over; these iterators split a row off the front instead.

/// The rows of `block`, row stride `n` (`n > 0`); a shorter tail is not a
/// row.
#[inline(always)]
pub(crate) fn rows(block: &[f64], n: usize) -> Rows<'_> {
    debug_assert!(n > 0, "a row has values");
    Rows { rest: block, n }
}

/// [`rows`], each row mutable.
#[inline(always)]
pub(crate) fn rows_mut(block: &mut [f64], n: usize) -> RowsMut<'_> {
    debug_assert!(n > 0, "a row has values");
    RowsMut { rest: block, n }
}

/// The iterator of [`rows`].
pub(crate) struct Rows<'a> {
    rest: &'a [f64],
    n: usize,
}

impl<'a> Iterator for Rows<'a> {
    type Item = &'a [f64];

    #[inline(always)]
    fn next(&mut self) -> Option<&'a [f64]> {
        let (row, rest) = self.rest.split_at_checked(self.n)?;
        self.rest = rest;
        Some(row)
    }
}

/// The iterator of [`rows_mut`].
pub(crate) struct RowsMut<'a> {
    rest: &'a mut [f64],
    n: usize,
}

impl<'a> Iterator for RowsMut<'a> {
    type Item = &'a mut [f64];

    #[inline(always)]
    fn next(&mut self) -> Option<&'a mut [f64]> {
        let (row, rest) = std::mem::take(&mut self.rest).split_at_mut_checked(self.n)?;
        self.rest = rest;
        Some(row)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_those_of_chunks_exact() {
        let mut block: Vec<f64> = (0..23).map(f64::from).collect();
        for n in [1, 2, 3, 5, 23, 24] {
            let want: Vec<&[f64]> = block.chunks_exact(n).collect();
            assert_eq!(rows(&block, n).collect::<Vec<_>>(), want, "n = {n}");
            let want: Vec<Vec<f64>> = block.chunks_exact(n).map(<[f64]>::to_vec).collect();
            let got: Vec<Vec<f64>> = rows_mut(&mut block, n).map(|r| r.to_vec()).collect();
            assert_eq!(got, want, "n = {n}");
        }
    }
}
