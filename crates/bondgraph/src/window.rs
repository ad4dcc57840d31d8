//! The last samples of a stream, oldest first, as one slice.

use crate::prelude::*;

/// A sliding window over the last `len` samples. Each sample is stored twice, `len` apart,
/// so that the window is always one contiguous slice, oldest first, with no copy per sample.
#[derive(Clone, Debug)]
pub(crate) struct Window<T> {
    buffer: Vec<T>,
    len: usize,
    /// Where the next sample goes (the oldest one once the buffer is full).
    next: usize,
    seen: usize,
}

impl<T: Copy> Window<T> {
    /// An empty window of `len` samples; `zero` fills it until samples come.
    pub(crate) fn new(len: usize, zero: T) -> Window<T> {
        Window {
            buffer: vec![zero; 2 * len],
            len,
            next: 0,
            seen: 0,
        }
    }

    /// Takes the next sample; once `len` were seen, the last `len`, oldest first.
    #[inline]
    pub(crate) fn push(&mut self, x: T) -> Option<&[T]> {
        let len = self.len;
        self.buffer[self.next] = x;
        self.buffer[self.next + len] = x;
        // A compare, not a division: this runs once per sample.
        self.next = if self.next + 1 == len {
            0
        } else {
            self.next + 1
        };
        self.seen = self.seen.saturating_add(1);
        if self.seen < len {
            return None;
        }
        Some(&self.buffer[self.next..self.next + len])
    }

    /// How many samples were taken.
    pub(crate) fn seen(&self) -> usize {
        self.seen
    }

    /// The last `k` samples (at most the window's length), oldest first; the zero stands
    /// for those not yet taken.
    pub(crate) fn last(&self, k: usize) -> &[T] {
        let end = self.next + self.len;
        &self.buffer[end - k.min(self.len)..end]
    }

    /// Takes the samples `xs` in turn.
    pub(crate) fn extend(&mut self, xs: &[T]) {
        // Only the last `len` stay.
        let kept = xs.len().saturating_sub(self.len);
        for &x in &xs[kept..] {
            self.push(x);
        }
        self.seen = self.seen.saturating_add(kept);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_holds_the_last_samples_oldest_first() {
        let mut w = Window::new(3, 0);
        assert_eq!(w.push(1), None);
        assert_eq!(w.push(2), None);
        assert_eq!(w.push(3), Some(&[1, 2, 3][..]));
        assert_eq!(w.push(4), Some(&[2, 3, 4][..]));
        assert_eq!(w.push(5), Some(&[3, 4, 5][..]));
        assert_eq!(w.push(6), Some(&[4, 5, 6][..]));
        assert_eq!(w.push(7), Some(&[5, 6, 7][..]));
    }

    #[test]
    fn extending_is_pushing_each_in_turn() {
        let mut w = Window::new(3, 0);
        assert_eq!(w.last(2), &[0, 0]);
        w.extend(&[1]);
        assert_eq!((w.seen(), w.last(2)), (1, &[0, 1][..]));
        w.extend(&[2, 3, 4, 5, 6]);
        assert_eq!((w.seen(), w.last(3)), (6, &[4, 5, 6][..]));
        assert_eq!(w.push(7), Some(&[5, 6, 7][..]));
    }
}
