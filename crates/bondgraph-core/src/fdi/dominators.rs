//! Dominators of a directed graph from a root (Lengauer and Tarjan, the simple version with
//! path compression: O(E log V)), iterative so that a long chain cannot overflow the stack.
//!
//! A node `d` dominates `v` when every path from the root to `v` goes through `d`. Which
//! equations lose their redundancy with one equation is exactly such a question.

const NONE: u32 = u32::MAX;

/// The immediate dominator of every node of the graph `successors` from `root`: `None` for
/// the root and for nodes it does not reach.
pub fn immediate(successors: &[Vec<u32>], root: u32) -> Vec<Option<u32>> {
    let n = successors.len();
    // Depth-first preorder numbering; the tree parent of each node, by number.
    let mut number = vec![NONE; n];
    let mut vertex: Vec<u32> = Vec::with_capacity(n);
    let mut parent: Vec<u32> = Vec::with_capacity(n);
    let mut stack: Vec<(u32, u32)> = vec![(root, NONE)];
    while let Some((v, from)) = stack.pop() {
        if number[v as usize] != NONE {
            continue;
        }
        number[v as usize] = vertex.len() as u32;
        vertex.push(v);
        parent.push(from);
        for &w in successors[v as usize].iter().rev() {
            if number[w as usize] == NONE {
                stack.push((w, number[v as usize]));
            }
        }
    }
    let reached = vertex.len();
    let mut predecessors: Vec<Vec<u32>> = vec![Vec::new(); reached];
    for (i, &v) in vertex.iter().enumerate() {
        for &w in &successors[v as usize] {
            let k = number[w as usize];
            if k != NONE {
                predecessors[k as usize].push(i as u32);
            }
        }
    }
    let mut semi: Vec<u32> = (0..reached as u32).collect();
    let mut label: Vec<u32> = (0..reached as u32).collect();
    let mut ancestor = vec![NONE; reached];
    let mut idom = vec![NONE; reached];
    let mut bucket: Vec<Vec<u32>> = vec![Vec::new(); reached];
    for w in (1..reached).rev() {
        for &v in &predecessors[w] {
            let u = eval(v, &mut ancestor, &mut label, &semi);
            if semi[u as usize] < semi[w] {
                semi[w] = semi[u as usize];
            }
        }
        bucket[semi[w] as usize].push(w as u32);
        let p = parent[w];
        ancestor[w] = p;
        for v in std::mem::take(&mut bucket[p as usize]) {
            let u = eval(v, &mut ancestor, &mut label, &semi);
            idom[v as usize] = if semi[u as usize] < semi[v as usize] {
                u
            } else {
                p
            };
        }
    }
    for w in 1..reached {
        if idom[w] != semi[w] {
            idom[w] = idom[idom[w] as usize];
        }
    }
    let mut out = vec![None; n];
    for w in 1..reached {
        out[vertex[w] as usize] = Some(vertex[idom[w] as usize]);
    }
    out
}

/// The node of least semidominator on the forest path from `v` up to its tree root.
fn eval(v: u32, ancestor: &mut [u32], label: &mut [u32], semi: &[u32]) -> u32 {
    if ancestor[v as usize] == NONE {
        return v;
    }
    // Path compression, top of the path first, as the recursive form does it.
    let mut path = Vec::new();
    let mut u = v;
    while ancestor[ancestor[u as usize] as usize] != NONE {
        path.push(u);
        u = ancestor[u as usize];
    }
    while let Some(u) = path.pop() {
        let a = ancestor[u as usize];
        if semi[label[a as usize] as usize] < semi[label[u as usize] as usize] {
            label[u as usize] = label[a as usize];
        }
        ancestor[u as usize] = ancestor[a as usize];
    }
    label[v as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dominators by their definition: `d` dominates `v` when `v` is unreachable without `d`.
    fn by_definition(successors: &[Vec<u32>], root: u32) -> Vec<Option<u32>> {
        let n = successors.len();
        let reach = |without: Option<u32>| {
            let mut seen = vec![false; n];
            let mut stack = vec![root];
            while let Some(v) = stack.pop() {
                if Some(v) == without || seen[v as usize] {
                    continue;
                }
                seen[v as usize] = true;
                stack.extend(&successors[v as usize]);
            }
            seen
        };
        let all = reach(None);
        let dominated: Vec<Vec<bool>> = (0..n as u32)
            .map(|d| {
                let r = reach(Some(d));
                (0..n).map(|v| all[v] && !r[v] && v as u32 != d).collect()
            })
            .collect();
        // The immediate dominator: the strict dominator that the others dominate too.
        (0..n)
            .map(|v| {
                let strict: Vec<u32> = (0..n as u32)
                    .filter(|&d| dominated[d as usize][v])
                    .collect();
                strict.iter().copied().find(|&d| {
                    strict
                        .iter()
                        .all(|&o| o == d || dominated[o as usize][d as usize])
                })
            })
            .collect()
    }

    /// Pseudo-random graphs against the definition.
    #[test]
    fn immediate_dominators_match_their_definition() {
        let mut seed = 0x2545_f491_u64;
        let mut next = |m: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % m) as u32
        };
        for n in [2u32, 5, 9, 14, 25] {
            for _ in 0..40 {
                let mut g: Vec<Vec<u32>> = vec![Vec::new(); n as usize];
                for _ in 0..(2 * n) {
                    let (a, b) = (next(n as u64), next(n as u64));
                    g[a as usize].push(b);
                }
                assert_eq!(immediate(&g, 0), by_definition(&g, 0), "{g:?}");
            }
        }
    }

    /// A path of a million nodes with edges both ways: no recursion.
    #[test]
    fn a_long_two_way_path() {
        let n = 1_000_000u32;
        let g: Vec<Vec<u32>> = (0..n)
            .map(|i| {
                let mut s = Vec::new();
                if i + 1 < n {
                    s.push(i + 1);
                }
                if i > 0 {
                    s.push(i - 1);
                }
                s
            })
            .collect();
        let d = immediate(&g, 0);
        assert_eq!(d[0], None);
        assert!((1..n).all(|i| d[i as usize] == Some(i - 1)));
    }
}
