//! The structure of a set of equations: which unknowns each one holds, as a bipartite graph,
//! with a maximum matching and the over-determined part of the Dulmage–Mendelsohn
//! decomposition. What a structural analysis of redundancy needs, and nothing else: whether a
//! law can actually be solved for an unknown is the causality's business, not this one's.

/// An equation of a [`Structure`], by position.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Eq(pub u32);

/// Equations over unknowns `0..vars`.
#[derive(Clone, Debug, Default)]
pub struct Structure {
    rows: Vec<Vec<u32>>,
    /// For each unknown, the equations that hold it.
    columns: Vec<Vec<u32>>,
}

/// A maximum matching of equations to unknowns, over a subset of the equations.
#[derive(Clone, Debug)]
pub struct Matching {
    /// The unknown each equation computes, if any.
    eq_var: Vec<Option<u32>>,
    /// The equation that computes each unknown, if any.
    var_eq: Vec<Option<u32>>,
}

const NONE: u32 = u32::MAX;

impl Structure {
    /// No equations over `vars` unknowns.
    pub fn new(vars: usize) -> Structure {
        Structure {
            rows: Vec::new(),
            columns: vec![Vec::new(); vars],
        }
    }

    /// Adds an equation over `vars` (each below the count given to [`Structure::new`], or a
    /// new one added with [`Structure::add_var`]).
    pub fn push(&mut self, mut vars: Vec<u32>) -> Eq {
        vars.sort_unstable();
        vars.dedup();
        let e = self.rows.len() as u32;
        for &v in &vars {
            self.columns[v as usize].push(e);
        }
        self.rows.push(vars);
        Eq(e)
    }

    /// A new unknown, held by no equation yet.
    pub fn add_var(&mut self) -> u32 {
        self.columns.push(Vec::new());
        (self.columns.len() - 1) as u32
    }

    /// Adds unknown `v` to equation `e`.
    pub fn add_to(&mut self, e: Eq, v: u32) {
        let row = &mut self.rows[e.0 as usize];
        if !row.contains(&v) {
            row.push(v);
            self.columns[v as usize].push(e.0);
        }
    }

    /// The number of equations.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// The unknowns of equation `e`.
    #[cfg(test)]
    pub fn vars(&self, e: Eq) -> &[u32] {
        &self.rows[e.0 as usize]
    }

    /// A maximum matching of the equations in `active` (Hopcroft–Karp: O(E·√V)).
    pub fn matching(&self, active: &[bool]) -> Matching {
        let mut m = Matching {
            eq_var: vec![None; self.rows.len()],
            var_eq: vec![None; self.columns.len()],
        };
        // A greedy start leaves few augmenting paths to find.
        for (e, row) in self.rows.iter().enumerate() {
            if !active[e] {
                continue;
            }
            if let Some(&v) = row.iter().find(|&&v| m.var_eq[v as usize].is_none()) {
                m.eq_var[e] = Some(v);
                m.var_eq[v as usize] = Some(e as u32);
            }
        }
        while self.augment_phase(active, &mut m) {}
        m
    }

    /// One phase of Hopcroft–Karp: the layers of shortest alternating paths from the free
    /// equations, then a maximal set of disjoint augmenting paths along them. Whether any.
    fn augment_phase(&self, active: &[bool], m: &mut Matching) -> bool {
        let n = self.rows.len();
        let mut layer = vec![NONE; n];
        let mut queue: Vec<u32> = (0..n as u32)
            .filter(|&e| active[e as usize] && m.eq_var[e as usize].is_none())
            .collect();
        for &e in &queue {
            layer[e as usize] = 0;
        }
        let mut found = false;
        let mut head = 0;
        while head < queue.len() {
            let e = queue[head];
            head += 1;
            for &v in &self.rows[e as usize] {
                match m.var_eq[v as usize] {
                    None => found = true,
                    Some(next) if layer[next as usize] == NONE => {
                        layer[next as usize] = layer[e as usize] + 1;
                        queue.push(next);
                    }
                    Some(_) => {}
                }
            }
        }
        if !found {
            return false;
        }
        let mut next_edge = vec![0usize; n];
        let mut any = false;
        for start in 0..n as u32 {
            if active[start as usize]
                && m.eq_var[start as usize].is_none()
                && layer[start as usize] == 0
            {
                any |= self.augment_from(start, &mut layer, &mut next_edge, m);
            }
        }
        any
    }

    /// An augmenting path from free equation `start` along increasing layers (iterative, so
    /// that a long chain cannot overflow the stack); applies it if found.
    fn augment_from(
        &self,
        start: u32,
        layer: &mut [u32],
        next_edge: &mut [usize],
        m: &mut Matching,
    ) -> bool {
        // The path so far: equations, and the unknown each takes.
        let mut path: Vec<(u32, u32)> = Vec::new();
        let mut e = start;
        loop {
            let row = &self.rows[e as usize];
            let mut advanced = false;
            while next_edge[e as usize] < row.len() {
                let v = row[next_edge[e as usize]];
                next_edge[e as usize] += 1;
                match m.var_eq[v as usize] {
                    None => {
                        path.push((e, v));
                        for &(pe, pv) in &path {
                            m.eq_var[pe as usize] = Some(pv);
                            m.var_eq[pv as usize] = Some(pe);
                        }
                        return true;
                    }
                    Some(next) if layer[next as usize] == layer[e as usize] + 1 => {
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
            layer[e as usize] = NONE;
            match path.pop() {
                Some((previous, _)) => e = previous,
                None => return false,
            }
        }
    }

    /// The over-determined part `M⁺` of the equations in `active`, given a maximum matching
    /// of them: the equations an alternating path reaches from an unmatched equation.
    pub fn overdetermined(&self, active: &[bool], m: &Matching) -> Vec<bool> {
        let mut plus = vec![false; self.rows.len()];
        let mut stack: Vec<u32> = (0..self.rows.len() as u32)
            .filter(|&e| active[e as usize] && m.eq_var[e as usize].is_none())
            .collect();
        for &e in &stack {
            plus[e as usize] = true;
        }
        while let Some(e) = stack.pop() {
            for &v in &self.rows[e as usize] {
                if let Some(next) = m.var_eq[v as usize] {
                    if !plus[next as usize] {
                        plus[next as usize] = true;
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
    pub fn without(&self, active: &[bool], m: &Matching, e: Eq) -> Vec<bool> {
        let mut active = active.to_vec();
        active[e.0 as usize] = false;
        let mut m = m.clone();
        if let Some(x) = m.eq_var[e.0 as usize].take() {
            m.var_eq[x as usize] = None;
            self.rematch(&active, &mut m, x);
        }
        self.overdetermined(&active, &m)
    }

    /// Matches the free unknown `x` by one augmenting path (breadth first), if there is one.
    #[cfg(test)]
    fn rematch(&self, active: &[bool], m: &mut Matching, x: u32) {
        // For each equation reached, the unknown it was reached from.
        let mut from: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
        let mut queue = std::collections::VecDeque::from([x]);
        let mut seen_var = std::collections::HashSet::from([x]);
        while let Some(v) = queue.pop_front() {
            for &e in &self.columns[v as usize] {
                if !active[e as usize] || from.contains_key(&e) {
                    continue;
                }
                from.insert(e, v);
                match m.eq_var[e as usize] {
                    None => {
                        // Flip the path back to `x`.
                        let mut e = e;
                        loop {
                            let v = from[&e];
                            let previous = m.var_eq[v as usize];
                            m.eq_var[e as usize] = Some(v);
                            m.var_eq[v as usize] = Some(e);
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
    /// The number of matched pairs.
    /// How many unknowns it matches.
    pub fn size(&self) -> usize {
        self.eq_var.iter().filter(|v| v.is_some()).count()
    }

    /// Whether equation `e` computes no unknown.
    pub fn is_free(&self, e: u32) -> bool {
        self.eq_var[e as usize].is_none()
    }

    /// Moves the freedom along an alternating path `r → g₁ → … → e` (each equation holding
    /// the unknown the next computes): `r`, free, takes `g₁`'s unknown, and so on, and `e`
    /// is left free. The matching stays maximum.
    pub fn shift(&mut self, path: &[u32]) {
        for pair in path.windows(2) {
            let (h, g) = (pair[0], pair[1]);
            if let Some(x) = self.eq_var[g as usize] {
                self.eq_var[h as usize] = Some(x);
                self.var_eq[x as usize] = Some(h);
            }
        }
        if let (Some(&e), true) = (path.last(), path.len() > 1) {
            self.eq_var[e as usize] = None;
        }
    }
}

impl Structure {
    /// The alternating-path graph of `active` under `m`: an edge from each equation to each
    /// equation that computes one of its other unknowns.
    pub fn alternating(&self, active: &[bool], m: &Matching) -> Vec<Vec<u32>> {
        self.rows
            .iter()
            .enumerate()
            .map(|(h, row)| {
                if !active[h] {
                    return Vec::new();
                }
                row.iter()
                    .filter_map(|&v| m.var_eq[v as usize])
                    .filter(|&g| g as usize != h && active[g as usize])
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
            s.push(r.to_vec());
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
        s.push(vec![0]);
        for i in 1..n {
            s.push(vec![i - 1, i]);
        }
        s.push(vec![n - 1]);
        let all = vec![true; s.len()];
        let m = s.matching(&all);
        assert_eq!(m.size(), n as usize);
        assert!(s.overdetermined(&all, &m).iter().all(|&p| p));
    }
}
