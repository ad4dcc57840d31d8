//! Subsets of a set, by size: the exhaustive searches (sensor placement, the smallest set of
//! residuals) try every set of one, then two… elements, within a budget.

/// Calls `f` on every `size`-subset of `0..n` in lexicographic order while `budget` lasts;
/// whether all were visited.
pub(super) fn for_each_subset(
    n: usize,
    size: usize,
    budget: &mut usize,
    mut f: impl FnMut(&[usize]),
) -> bool {
    if size > n {
        return true;
    }
    let mut set: Vec<usize> = (0..size).collect();
    loop {
        if *budget == 0 {
            return false;
        }
        *budget -= 1;
        f(&set);
        // The next combination: the rightmost index that can move, moved, the rest after it.
        let Some(i) = (0..size).rev().find(|&i| set[i] < n - size + i) else {
            return true;
        };
        set[i] += 1;
        for k in i + 1..size {
            set[k] = set[k - 1] + 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subsets_are_all_visited_once() {
        let mut seen = Vec::new();
        let mut budget = 100;
        assert!(for_each_subset(5, 2, &mut budget, |s| seen.push(s.to_vec())));
        assert_eq!(seen.len(), 10);
        assert_eq!(seen[0], [0, 1]);
        assert_eq!(seen[9], [3, 4]);
        let mut budget = 3;
        assert!(!for_each_subset(5, 2, &mut budget, |_| {}));
    }
}
