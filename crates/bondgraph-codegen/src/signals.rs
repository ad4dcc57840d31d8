//! The fields of a generator's `Signals`, one per slot of the residual program: what every
//! backend that prints the program names them and says of them.

use bondgraph_core::program::{Program, Slot};
use bondgraph_core::{Compiled, Handle, Printer, Quantity, Readings, Signal};

use crate::names;

/// One field of `Signals`: one slot of the program.
pub(crate) struct Field {
    pub(crate) name: String,
    pub(crate) slot: Handle<Slot>,
    pub(crate) doc: String,
}

/// The fields of `Signals`, one per slot of the program, in order: per signal its value,
/// derivatives and integral, then the integrals of nonlinear expressions, then the copy's
/// states.
pub(crate) fn fields(c: &Compiled, program: &Program, readings: &Readings) -> Vec<Field> {
    let printer = Printer::new(&c.exprs, |s| names::text(c, s));
    let name_of = |signal: Signal| match signal {
        Signal::Input(u) => (&c.inputs[u].name, "input"),
        Signal::Sensor(s) => (&c.sensors[s].name, "measured signal"),
    };
    (program.slots.iter())
        .map(|(slot, s)| {
            let (name, doc) = match s.quantity {
                Quantity::Derivative(signal, 0) => {
                    let (name, what) = name_of(signal);
                    (name.clone(), format!("The {what} `{name}`."))
                }
                Quantity::Derivative(signal, n) => {
                    let (name, _) = name_of(signal);
                    (
                        format!("{name}_d{n}"),
                        format!("The time derivative of order {n} of `{name}`."),
                    )
                }
                Quantity::Integral(signal) => {
                    let (name, _) = name_of(signal);
                    (
                        format!("{name}_int"),
                        format!("The integral of `{name}` from the start of the record."),
                    )
                }
                Quantity::Nonlinear(k) => (
                    format!("int{}", k + 1),
                    format!(
                        "`int({})`: the integral from the start of the record of an expression that is not linear in the signals.",
                        readings.nonlinear.get(k).map_or_else(String::new, |&e| printer.text(e))
                    ),
                ),
                Quantity::Simulated(k) => {
                    let name = &c.states[k].name;
                    (
                        format!("{name}_hat"),
                        format!("The state `{name}` of the copy of the model that simulated residuals run."),
                    )
                }
                Quantity::Root(k) => {
                    let root = &c.roots[k];
                    (
                        root.name.clone(),
                        format!(
                            "The root of `{} = 0`: the law of `{}`, which has no closed-form inverse, solved at each estimate.",
                            printer.text(root.residual),
                            root.element
                        ),
                    )
                }
            };
            Field { name, slot, doc }
        })
        .collect()
}
