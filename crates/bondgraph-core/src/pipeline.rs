//! The pipeline driver: runs the stages a request needs, in order, on a valid model; how
//! their expressions are shown is `display.rs`, how the product is built `product/`.

use crate::causality::{assign, Causal, Mode};
use crate::fdi::candidates::{self, Candidate, Origin, ResidualSet};
use crate::fdi::isolability::Classes;
use crate::fdi::partial::PartialCopy;
use crate::fdi::simulated::{self, Simulated};
use crate::fdi::Component;
use crate::fdi::{diagnose, Diagnosis, Fsm};
use crate::graph::BondGraph;
use crate::state_space::{state_space_of, StateSpace};

/// What the stages derived from a model; the product is built from it.
pub(crate) struct Analysis<'m> {
    /// The model.
    pub model: &'m BondGraph,
    /// Integral causality (simulation).
    pub integral: Causal,
    /// State equations.
    pub state: StateSpace,
    /// Diagnosis causality, ARRs and the FSM, when they were asked for.
    pub diagnosis: Option<Diagnosed>,
}

/// The residuals derived, and those kept.
pub(crate) struct Diagnosed {
    /// The derivations: the whole model first, then (with candidates) one per fault class
    /// left out.
    pub sources: Vec<Diagnosis>,
    /// The FSM of the whole model's ARRs: its components and the structural classes.
    pub fsm: Fsm,
    /// The residuals kept, in order, each with the components it shows.
    pub chosen: Vec<Candidate>,
    /// The classes every candidate together tells apart, when candidates were derived.
    pub candidates: Option<Classes>,
    /// The structural classes merged where derivations proved dependences cancel, when
    /// candidates were derived.
    pub bound: Option<Classes>,
    /// Which residuals were asked for.
    pub set: ResidualSet,
    /// Whether the model had too many classes for whole-model derivations (candidates came
    /// from the part around each class).
    pub capped: bool,
    /// The derivations that gave fewer residuals than the structure allows.
    pub unrealised: Vec<candidates::Unrealised>,
    /// The detectors' simulated residuals that the candidates hold.
    pub simulated: Vec<Simulated>,
    /// For each of them, the partial copy it runs, if it runs one rather than the model.
    pub copies: Vec<Option<PartialCopy>>,
}

impl Diagnosed {
    /// The whole model's derivation.
    pub(crate) fn base(&self) -> &Diagnosis {
        &self.sources[0]
    }
}

/// The rows each of the `arrs` ARRs shows, as the FSM found them.
fn shown_by(fsm: &Fsm, arrs: usize) -> Vec<Vec<usize>> {
    let mut rows: Vec<Vec<usize>> = vec![Vec::new(); arrs];
    for (r, row) in fsm.rows.iter().enumerate() {
        for &k in &row.marks {
            rows[k].push(r);
        }
    }
    rows
}

/// Every candidate residual of `model` (the structural classes' derivations included), over
/// how many components: what `--residuals best` chooses from.
pub(crate) fn candidate_list(model: &BondGraph) -> (Vec<Candidate>, usize) {
    let d = diagnose(model);
    let fsm = Fsm::new(model, &d);
    let components: Vec<Component> = fsm.rows.iter().map(|r| r.component.clone()).collect();
    let rows = shown_by(&fsm, d.arrs.len());
    let found = candidates::candidates(model, d, rows, &components, &fsm.possible);
    (found.list, components.len())
}

/// The most work (detectors times equations) spent on the detectors' simulated residuals:
/// each one's output depends on most of a connected model, so their dependences cost that
/// product (about a second at this bound).
const MAX_SIMULATED_WORK: usize = 20_000_000;

/// Each detector's simulated residual, with its candidate (the components it shows): none
/// where a copy of the model cannot be run (see [`simulated::simulated`]) or past
/// [`MAX_SIMULATED_WORK`].
fn simulated_candidates(
    model: &BondGraph,
    (integral, state): (&Causal, &StateSpace),
    components: &[Component],
) -> (Vec<Simulated>, Vec<Candidate>) {
    let work = state.outputs.len() * integral.system.equations.len();
    if work > MAX_SIMULATED_WORK {
        return (Vec::new(), Vec::new());
    }
    let index = crate::fdi::RowIndex::new(components);
    let found = simulated::simulated(model, integral, state);
    let with = (found.iter().enumerate())
        .map(|(k, s)| Candidate {
            origin: Origin::Simulated(k),
            without: Vec::new(),
            order: 0,
            rows: simulated::rows(s, components, &index),
        })
        .collect();
    (found, with)
}

/// Adds to `list` every detector's simulated residual, asked for as they are (the output
/// error).
fn every_simulated(
    model: &BondGraph,
    simulation: (&Causal, &StateSpace),
    fsm: &Fsm,
    list: &mut Vec<Candidate>,
) -> Vec<Simulated> {
    let components: Vec<Component> = fsm.rows.iter().map(|r| r.component.clone()).collect();
    let (found, with) = simulated_candidates(model, simulation, &components);
    list.extend(with);
    found
}

/// Adds to `list` every detector's residual against its partial copy (see
/// [`crate::fdi::partial`]), with the copies.
fn every_partial(
    model: &BondGraph,
    (integral, state): (&Causal, &StateSpace),
    fsm: &Fsm,
    list: &mut Vec<Candidate>,
) -> (Vec<Simulated>, Vec<Option<PartialCopy>>) {
    let components: Vec<Component> = fsm.rows.iter().map(|r| r.component.clone()).collect();
    if state.outputs.len() * integral.system.equations.len() > MAX_SIMULATED_WORK {
        return (Vec::new(), Vec::new());
    }
    let index = crate::fdi::RowIndex::new(&components);
    let (found, copies): (Vec<Simulated>, Vec<PartialCopy>) =
        simulated::partial(model, integral, state)
            .into_iter()
            .unzip();
    list.extend(found.iter().enumerate().map(|(k, s)| Candidate {
        origin: Origin::Simulated(k),
        without: Vec::new(),
        order: 0,
        rows: simulated::rows(s, &components, &index),
    }));
    (found, copies.into_iter().map(Some).collect())
}

/// Adds to `list` the detectors' simulated residuals, when together they tell apart classes
/// that the derived residuals do not: a residual that needs a copy of the model run from a
/// known state is kept for what no relation of measured signals can show. Returns those
/// added. Not tried when the derived residuals reach the structural classes already.
fn add_simulated(
    model: &BondGraph,
    simulation: (&Causal, &StateSpace),
    fsm: &Fsm,
    list: &mut Vec<Candidate>,
) -> Vec<Simulated> {
    let components: Vec<Component> = fsm.rows.iter().map(|r| r.component.clone()).collect();
    let n = components.len();
    let before = candidates::classes_of(&list.iter().collect::<Vec<_>>(), n);
    if before.classes.len() >= fsm.possible.classes.len() {
        return Vec::new();
    }
    let (found, with) = simulated_candidates(model, simulation, &components);
    let all: Vec<&Candidate> = list.iter().chain(&with).collect();
    if candidates::classes_of(&all, n).classes.len() <= before.classes.len() {
        return Vec::new();
    }
    list.extend(with);
    found
}

/// The ARRs of `model`, with candidates beyond one per detector unless `set` asks only for
/// those; the detectors' simulated residuals from the state equations of `simulation`
/// join them where they tell more classes apart.
fn diagnosed(model: &BondGraph, set: ResidualSet, simulation: (&Causal, &StateSpace)) -> Diagnosed {
    let d = diagnose(model);
    let fsm = Fsm::new(model, &d);
    let components: Vec<Component> = fsm.rows.iter().map(|r| r.component.clone()).collect();
    let possible = if set.per_detector() {
        // One derivation only: the whole model's ARRs, as they are.
        Classes::default()
    } else {
        fsm.possible.clone()
    };
    let rows = shown_by(&fsm, d.arrs.len());
    let mut found = candidates::candidates(model, d, rows, &components, &possible);
    let (simulated, copies) = match set {
        ResidualSet::PerSensor => (Vec::new(), Vec::new()),
        ResidualSet::Simulated => {
            let found = every_simulated(model, simulation, &fsm, &mut found.list);
            let copies = found.iter().map(|_| None).collect();
            (found, copies)
        }
        ResidualSet::Partial | ResidualSet::Bank => {
            every_partial(model, simulation, &fsm, &mut found.list)
        }
        ResidualSet::Best | ResidualSet::All => {
            let found = add_simulated(model, simulation, &fsm, &mut found.list);
            let copies = found.iter().map(|_| None).collect();
            (found, copies)
        }
    };
    let all: Vec<&Candidate> = found.list.iter().collect();
    let classes = candidates::classes_of(&all, components.len());
    let chosen = candidates::select(&found.list, components.len(), set)
        .into_iter()
        .map(|k| found.list[k].clone())
        .collect();
    Diagnosed {
        sources: found.sources,
        fsm,
        chosen,
        candidates: (!set.per_detector()).then_some(classes),
        bound: (!set.per_detector()).then(|| candidates::bound(&possible, &found.unrealised)),
        set,
        capped: found.capped,
        unrealised: found.unrealised,
        simulated,
        copies,
    }
}

/// Runs the pipeline on a valid model: the state equations always, the ARRs and FSM when
/// `diagnose` says so.
pub(crate) fn analyse(model: &BondGraph, with_arrs: bool, set: ResidualSet) -> Analysis<'_> {
    let integral = assign(model, Mode::Integral);
    let state = state_space_of(model, &integral);
    let diagnosis = with_arrs.then(|| diagnosed(model, set, (&integral, &state)));
    Analysis {
        model,
        integral,
        state,
        diagnosis,
    }
}
