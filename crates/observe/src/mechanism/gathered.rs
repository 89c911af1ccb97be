//! A batch's items gathered for a call that takes them as a slice, on the
//! stack when they are few: a calibration's passes hand the mechanism
//! its touches a solver's batch at a time, some hundred thousand batches
//! a pass, and a vector per batch would be as many allocations.

/// The most items [`gathered`] keeps on the stack: two batches of the
/// hexapod's four SIMD lanes.
pub const ON_STACK: usize = 8;

/// `f` of the `n` items `item(0)`, ..., `item(n - 1)` as a slice: on the
/// stack for at most [`ON_STACK`] items, in a vector for more.
pub fn gathered<T: Copy, R>(n: usize, item: impl Fn(usize) -> T, f: impl FnOnce(&[T]) -> R) -> R {
    if n == 0 || n > ON_STACK {
        let items: Vec<T> = (0..n).map(item).collect();
        return f(&items);
    }
    let first = item(0);
    let mut items = [first; ON_STACK];
    for (slot, k) in items[1..n].iter_mut().zip(1..) {
        *slot = item(k);
    }
    f(&items[..n])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_items_come_in_order_however_many() {
        for n in [0, 1, 3, ON_STACK, ON_STACK + 1, 20] {
            let squares = gathered(n, |k| k * k, <[usize]>::to_vec);
            let expected: Vec<usize> = (0..n).map(|k| k * k).collect();
            assert_eq!(squares, expected, "{n} items");
        }
    }
}
