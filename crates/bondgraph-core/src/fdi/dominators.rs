//! Dominators of a directed graph from a root (Lengauer and Tarjan, the simple version with
//! path compression: O(E log V)), iterative so that a long chain cannot overflow the stack.
//!
//! A node `d` dominates `v` when every path from the root to `v` goes through `d`. Which
//! equations lose their redundancy with one equation is exactly such a question.

use crate::index::{typed_index, Idx, IndexVec};

typed_index! {
    /// A node by its number in depth-first preorder from the root.
    struct Pre;
}

/// No node: the root's parent, an unset ancestor or dominator.
const NONE: Pre = Pre(u32::MAX);

/// The immediate dominator of every node of the graph `successors` from `root`: `None` for
/// the root and for nodes it does not reach.
pub(super) fn immediate<I: Idx>(
    successors: &IndexVec<I, Vec<I>>,
    root: I,
) -> IndexVec<I, Option<I>> {
    let n = successors.len();
    // Depth-first preorder numbering; the tree parent of each node, by number.
    let mut number: IndexVec<I, Option<Pre>> = IndexVec::from_elem(None, n);
    let mut vertex: IndexVec<Pre, I> = IndexVec::default();
    let mut parent: IndexVec<Pre, Pre> = IndexVec::default();
    let mut stack: Vec<(I, Pre)> = vec![(root, NONE)];
    while let Some((v, from)) = stack.pop() {
        if number[v].is_some() {
            continue;
        }
        let k = vertex.push(v);
        number[v] = Some(k);
        parent.push(from);
        for &w in successors[v].iter().rev() {
            if number[w].is_none() {
                stack.push((w, k));
            }
        }
    }
    let reached = vertex.len();
    let mut predecessors: IndexVec<Pre, Vec<Pre>> = IndexVec::from_elem(Vec::new(), reached);
    for (i, &v) in vertex.iter_enumerated() {
        for &w in &successors[v] {
            if let Some(k) = number[w] {
                predecessors[k].push(i);
            }
        }
    }
    let mut semi: IndexVec<Pre, Pre> = vertex.indices().collect();
    let mut label: IndexVec<Pre, Pre> = vertex.indices().collect();
    let mut ancestor: IndexVec<Pre, Pre> = IndexVec::from_elem(NONE, reached);
    let mut idom: IndexVec<Pre, Pre> = IndexVec::from_elem(NONE, reached);
    let mut bucket: IndexVec<Pre, Vec<Pre>> = IndexVec::from_elem(Vec::new(), reached);
    for w in vertex.indices().skip(1).rev() {
        for &v in &predecessors[w] {
            let u = eval(v, &mut ancestor, &mut label, &semi);
            if semi[u] < semi[w] {
                semi[w] = semi[u];
            }
        }
        let s = semi[w];
        bucket[s].push(w);
        let p = parent[w];
        ancestor[w] = p;
        for v in std::mem::take(&mut bucket[p]) {
            let u = eval(v, &mut ancestor, &mut label, &semi);
            idom[v] = if semi[u] < semi[v] { u } else { p };
        }
    }
    for w in vertex.indices().skip(1) {
        if idom[w] != semi[w] {
            idom[w] = idom[idom[w]];
        }
    }
    let mut out = IndexVec::from_elem(None, n);
    for w in vertex.indices().skip(1) {
        out[vertex[w]] = Some(vertex[idom[w]]);
    }
    out
}

/// The node of least semidominator on the forest path from `v` up to its tree root.
fn eval(
    v: Pre,
    ancestor: &mut IndexVec<Pre, Pre>,
    label: &mut IndexVec<Pre, Pre>,
    semi: &IndexVec<Pre, Pre>,
) -> Pre {
    if ancestor[v] == NONE {
        return v;
    }
    // Path compression, top of the path first, as the recursive form does it.
    let mut path = Vec::new();
    let mut u = v;
    while ancestor[ancestor[u]] != NONE {
        path.push(u);
        u = ancestor[u];
    }
    while let Some(u) = path.pop() {
        let a = ancestor[u];
        if semi[label[a]] < semi[label[u]] {
            label[u] = label[a];
        }
        ancestor[u] = ancestor[a];
    }
    label[v]
}

#[cfg(test)]
mod tests {
    use super::*;

    typed_index! {
        /// A node of a test graph.
        struct N;
    }

    /// Dominators by their definition: `d` dominates `v` when `v` is unreachable without `d`.
    fn by_definition(successors: &IndexVec<N, Vec<N>>, root: N) -> IndexVec<N, Option<N>> {
        let n = successors.len();
        let reach = |without: Option<N>| {
            let mut seen: IndexVec<N, bool> = IndexVec::from_elem(false, n);
            let mut stack = vec![root];
            while let Some(v) = stack.pop() {
                if Some(v) == without || seen[v] {
                    continue;
                }
                seen[v] = true;
                stack.extend(&successors[v]);
            }
            seen
        };
        let all = reach(None);
        let dominated: IndexVec<N, IndexVec<N, bool>> = successors
            .indices()
            .map(|d| {
                let r = reach(Some(d));
                successors
                    .indices()
                    .map(|v| all[v] && !r[v] && v != d)
                    .collect()
            })
            .collect();
        // The immediate dominator: the strict dominator that the others dominate too.
        successors
            .indices()
            .map(|v| {
                let strict: Vec<N> = successors.indices().filter(|&d| dominated[d][v]).collect();
                strict
                    .iter()
                    .copied()
                    .find(|&d| strict.iter().all(|&o| o == d || dominated[o][d]))
            })
            .collect()
    }

    /// Pseudo-random graphs against the definition.
    #[test]
    fn immediate_dominators_match_their_definition() {
        let mut seed = 0x2545_f491_u64;
        let mut next = |m: usize| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            N::new((seed % m as u64) as usize)
        };
        for n in [2usize, 5, 9, 14, 25] {
            for _ in 0..40 {
                let mut g: IndexVec<N, Vec<N>> = IndexVec::from_elem(Vec::new(), n);
                for _ in 0..(2 * n) {
                    let (a, b) = (next(n), next(n));
                    g[a].push(b);
                }
                assert_eq!(immediate(&g, N(0)), by_definition(&g, N(0)), "{g:?}");
            }
        }
    }

    /// A path of a million nodes with edges both ways: no recursion.
    #[test]
    fn a_long_two_way_path() {
        let n = 1_000_000u32;
        let g: IndexVec<N, Vec<N>> = (0..n)
            .map(|i| {
                let mut s = Vec::new();
                if i + 1 < n {
                    s.push(N(i + 1));
                }
                if i > 0 {
                    s.push(N(i - 1));
                }
                s
            })
            .collect();
        let d = immediate(&g, N(0));
        assert_eq!(d[N(0)], None);
        assert!((1..n).all(|i| d[N(i)] == Some(N(i - 1))));
    }
}
