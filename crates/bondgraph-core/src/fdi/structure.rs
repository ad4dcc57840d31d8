//! The structure of a set of equations: which unknowns each one holds, as a bipartite graph,
//! with a maximum matching and the over-determined part of the Dulmage–Mendelsohn
//! decomposition. What a structural analysis of redundancy needs, and nothing else: whether a
//! law can actually be solved for an unknown is the causality's business, not this one's.

use crate::index::{typed_index, Idx, IndexVec};

typed_index! {
    /// An equation of a [`Structure`], by position.
    pub(crate) struct Eq;
}

typed_index! {
    /// An unknown of a [`Structure`], by position.
    pub(crate) struct Unknown;
}

/// Equations over unknowns `0..vars`.
#[derive(Clone, Debug, Default)]
pub(crate) struct Structure {
    rows: IndexVec<Eq, Vec<Unknown>>,
    /// For each unknown, the equations that hold it.
    columns: IndexVec<Unknown, Vec<Eq>>,
}

/// A maximum matching of equations to unknowns, over a subset of the equations.
#[derive(Clone, Debug)]
pub(crate) struct Matching {
    /// The unknown each equation computes, if any.
    eq_var: IndexVec<Eq, Option<Unknown>>,
    /// The equation that computes each unknown, if any.
    var_eq: IndexVec<Unknown, Option<Eq>>,
}

/// A layer no alternating path has reached.
const NONE: u32 = u32::MAX;

impl Structure {
    /// No equations over `vars` unknowns.
    pub(crate) fn new(vars: usize) -> Structure {
        Structure {
            rows: IndexVec::default(),
            columns: IndexVec::from_elem(Vec::new(), vars),
        }
    }

    /// Adds an equation over `vars` (each below the count given to [`Structure::new`], or a
    /// new one added with [`Structure::add_var`]).
    pub(crate) fn push(&mut self, mut vars: Vec<Unknown>) -> Eq {
        vars.sort_unstable();
        vars.dedup();
        let e = Eq::new(self.rows.len());
        for &v in &vars {
            self.columns[v].push(e);
        }
        self.rows.push(vars)
    }

    /// A new unknown, held by no equation yet.
    pub(crate) fn add_var(&mut self) -> Unknown {
        self.columns.push(Vec::new())
    }

    /// Adds unknown `v` to equation `e`.
    pub(crate) fn add_to(&mut self, e: Eq, v: Unknown) {
        let row = &mut self.rows[e];
        if !row.contains(&v) {
            row.push(v);
            self.columns[v].push(e);
        }
    }

    /// The number of equations.
    pub(crate) fn len(&self) -> usize {
        self.rows.len()
    }

    /// Every equation, in order.
    pub(crate) fn equations(&self) -> impl DoubleEndedIterator<Item = Eq> + 'static {
        self.rows.indices()
    }

    /// The unknowns of equation `e`.
    #[cfg(test)]
    pub(crate) fn vars(&self, e: Eq) -> &[Unknown] {
        &self.rows[e]
    }

    /// A maximum matching of the equations in `active` (Hopcroft–Karp: O(E·√V)).
    pub(crate) fn matching(&self, active: &[bool]) -> Matching {
        let mut m = Matching {
            eq_var: IndexVec::from_elem(None, self.rows.len()),
            var_eq: IndexVec::from_elem(None, self.columns.len()),
        };
        // A greedy start leaves few augmenting paths to find.
        for (e, row) in self.rows.iter_enumerated() {
            if !active[e.index()] {
                continue;
            }
            if let Some(&v) = row.iter().find(|&&v| m.var_eq[v].is_none()) {
                m.eq_var[e] = Some(v);
                m.var_eq[v] = Some(e);
            }
        }
        while self.augment_phase(active, &mut m) {}
        m
    }

    /// The equations of `active` that compute no unknown under `m`.
    fn free<'a>(&'a self, active: &'a [bool], m: &'a Matching) -> impl Iterator<Item = Eq> + 'a {
        self.equations()
            .filter(move |&e| active[e.index()] && m.eq_var[e].is_none())
    }

    /// One phase of Hopcroft–Karp: the layers of shortest alternating paths from the free
    /// equations, then a maximal set of disjoint augmenting paths along them. Whether any.
    fn augment_phase(&self, active: &[bool], m: &mut Matching) -> bool {
        let mut layer: IndexVec<Eq, u32> = IndexVec::from_elem(NONE, self.rows.len());
        let mut queue: Vec<Eq> = self.free(active, m).collect();
        for &e in &queue {
            layer[e] = 0;
        }
        let mut found = false;
        let mut head = 0;
        while head < queue.len() {
            let e = queue[head];
            head += 1;
            for &v in &self.rows[e] {
                match m.var_eq[v] {
                    None => found = true,
                    Some(next) if layer[next] == NONE => {
                        layer[next] = layer[e] + 1;
                        queue.push(next);
                    }
                    Some(_) => {}
                }
            }
        }
        if !found {
            return false;
        }
        let mut next_edge: IndexVec<Eq, usize> = IndexVec::from_elem(0, self.rows.len());
        let starts: Vec<Eq> = self.free(active, m).collect();
        let mut any = false;
        for start in starts {
            if layer[start] == 0 {
                any |= self.augment_from(start, &mut layer, &mut next_edge, m);
            }
        }
        any
    }

    /// An augmenting path from free equation `start` along increasing layers (iterative, so
    /// that a long chain cannot overflow the stack); applies it if found.
    fn augment_from(
        &self,
        start: Eq,
        layer: &mut IndexVec<Eq, u32>,
        next_edge: &mut IndexVec<Eq, usize>,
        m: &mut Matching,
    ) -> bool {
        // The path so far: equations, and the unknown each takes.
        let mut path: Vec<(Eq, Unknown)> = Vec::new();
        let mut e = start;
        loop {
            let row = &self.rows[e];
            let mut advanced = false;
            while next_edge[e] < row.len() {
                let v = row[next_edge[e]];
                next_edge[e] += 1;
                match m.var_eq[v] {
                    None => {
                        path.push((e, v));
                        for &(pe, pv) in &path {
                            m.eq_var[pe] = Some(pv);
                            m.var_eq[pv] = Some(pe);
                        }
                        return true;
                    }
                    Some(next) if layer[next] == layer[e] + 1 => {
                        path.push((e, v));
                        e = next;
                        advanced = true;
                        break;
                    }
                    Some(_) => {}
                }
            }
            if advanced {
                continue;
            }
            // A dead end: never visit it again in this phase.
            layer[e] = NONE;
            match path.pop() {
                Some((previous, _)) => e = previous,
                None => return false,
            }
        }
    }

    /// The over-determined part `M⁺` of the equations in `active`, given a maximum matching
    /// of them: the equations an alternating path reaches from an unmatched equation.
    pub(crate) fn overdetermined(&self, active: &[bool], m: &Matching) -> Vec<bool> {
        let mut plus = vec![false; self.rows.len()];
        let mut stack: Vec<Eq> = self.free(active, m).collect();
        for &e in &stack {
            plus[e.index()] = true;
        }
        while let Some(e) = stack.pop() {
            for &v in &self.rows[e] {
                if let Some(next) = m.var_eq[v] {
                    if !plus[next.index()] {
                        plus[next.index()] = true;
                        stack.push(next);
                    }
                }
            }
        }
        plus
    }

    /// `(M \ {e})⁺` for `M` over-determined with maximum matching `m` (every unknown of `M`
    /// matched): `m` repaired by one augmenting path from the unknown `e` computed, then the
    /// over-determined part. O(E).
    #[cfg(test)]
    pub(crate) fn without(&self, active: &[bool], m: &Matching, e: Eq) -> Vec<bool> {
        let mut active = active.to_vec();
        active[e.index()] = false;
        let mut m = m.clone();
        if let Some(x) = m.eq_var[e].take() {
            m.var_eq[x] = None;
            self.rematch(&active, &mut m, x);
        }
        self.overdetermined(&active, &m)
    }

    /// Matches the free unknown `x` by one augmenting path (breadth first), if there is one.
    #[cfg(test)]
    fn rematch(&self, active: &[bool], m: &mut Matching, x: Unknown) {
        // For each equation reached, the unknown it was reached from.
        let mut from: std::collections::HashMap<Eq, Unknown> = std::collections::HashMap::new();
        let mut queue = std::collections::VecDeque::from([x]);
        let mut seen_var = std::collections::HashSet::from([x]);
        while let Some(v) = queue.pop_front() {
            for &e in &self.columns[v] {
                if !active[e.index()] || from.contains_key(&e) {
                    continue;
                }
                from.insert(e, v);
                match m.eq_var[e] {
                    None => {
                        // Flip the path back to `x`.
                        let mut e = e;
                        loop {
                            let v = from[&e];
                            let previous = m.var_eq[v];
                            m.eq_var[e] = Some(v);
                            m.var_eq[v] = Some(e);
                            match previous {
                                Some(p) if v != x => e = p,
                                _ => return,
                            }
                        }
                    }
                    Some(w) => {
                        if seen_var.insert(w) {
                            queue.push_back(w);
                        }
                    }
                }
            }
        }
    }
}

impl Matching {
    /// How many unknowns it matches.
    pub(crate) fn size(&self) -> usize {
        self.eq_var.iter().filter(|v| v.is_some()).count()
    }

    /// Whether equation `e` computes no unknown.
    pub(crate) fn is_free(&self, e: Eq) -> bool {
        self.eq_var[e].is_none()
    }

    /// Moves the freedom along an alternating path `r → g₁ → … → e` (each equation holding
    /// the unknown the next computes): `r`, free, takes `g₁`'s unknown, and so on, and `e`
    /// is left free. The matching stays maximum.
    pub(crate) fn shift(&mut self, path: &[Eq]) {
        for pair in path.windows(2) {
            let (h, g) = (pair[0], pair[1]);
            if let Some(x) = self.eq_var[g] {
                self.eq_var[h] = Some(x);
                self.var_eq[x] = Some(h);
            }
        }
        if let (Some(&e), true) = (path.last(), path.len() > 1) {
            self.eq_var[e] = None;
        }
    }
}

impl Structure {
    /// The alternating-path graph of `active` under `m`: an edge from each equation to each
    /// equation that computes one of its other unknowns.
    pub(crate) fn alternating(&self, active: &[bool], m: &Matching) -> IndexVec<Eq, Vec<Eq>> {
        self.rows
            .iter_enumerated()
            .map(|(h, row)| {
                if !active[h.index()] {
                    return Vec::new();
                }
                row.iter()
                    .filter_map(|&v| m.var_eq[v])
                    .filter(|&g| g != h && active[g.index()])
                    .collect()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn structure(rows: &[&[u32]], vars: usize) -> Structure {
        let mut s = Structure::new(vars);
        for r in rows {
            s.push(r.iter().map(|&v| Unknown(v)).collect());
        }
        s
    }

    /// Two measurements of one unknown, each with a law from another: x1 = f(x2), e2 sets
    /// x2, two sensors of x1. Four equations, two unknowns: redundancy 2, all over-determined.
    #[test]
    fn a_doubly_measured_unknown_is_over_determined() {
        let s = structure(&[&[0, 1], &[1], &[0], &[0]], 2);
        let all = vec![true; 4];
        let m = s.matching(&all);
        assert_eq!(m.size(), 2);
        assert_eq!(s.overdetermined(&all, &m), vec![true; 4]);
        // Without one sensor: redundancy 1, still all three.
        assert_eq!(s.without(&all, &m, Eq(2)), vec![true, true, false, true]);
        // Without the law setting x2: x2 is then set by nothing and e0 only computes it, so
        // the two sensors alone are redundant.
        assert_eq!(s.without(&all, &m, Eq(1)), vec![false, false, true, true]);
    }

    /// A just-determined part hanging off an over-determined one stays out of `M⁺`.
    #[test]
    fn a_just_determined_tail_is_not_over_determined() {
        // e0, e1 measure x0; e2 computes x1 from x0; e3 computes x2 from x1.
        let s = structure(&[&[0], &[0], &[0, 1], &[1, 2]], 3);
        let all = vec![true; 4];
        let m = s.matching(&all);
        assert_eq!(m.size(), 3);
        assert_eq!(s.overdetermined(&all, &m), vec![true, true, false, false]);
    }

    /// A long chain matches fully without recursion: 200,000 equations.
    #[test]
    fn a_long_chain_matches() {
        let n = 200_000u32;
        let mut s = Structure::new(n as usize);
        // Reversed so that the greedy start is as bad as it gets.
        s.push(vec![Unknown(0)]);
        for i in 1..n {
            s.push(vec![Unknown(i - 1), Unknown(i)]);
        }
        s.push(vec![Unknown(n - 1)]);
        let all = vec![true; s.len()];
        let m = s.matching(&all);
        assert_eq!(m.size(), n as usize);
        assert!(s.overdetermined(&all, &m).iter().all(|&p| p));
    }
}
