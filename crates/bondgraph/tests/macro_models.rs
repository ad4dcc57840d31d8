//! `bond_graph!` on models that compile, as a user's crate uses it: from a file (relative to
//! the crate's manifest directory), with `residuals = best`, `realise = direct` and a
//! parameter file (`params = "FILE"`), and
//! written inline with comments, units and descriptions. Warnings are errors: the generated
//! code must build clean in a crate that denies them.

#![deny(warnings)]

mod from_file {
    bondgraph::bond_graph!("../../models/rlc_series.bg");

    #[test]
    fn a_model_from_a_file_has_quiet_residuals_at_rest() {
        let p = rlc_series::Params::default();
        let s = rlc_series::Signals::from_array([0.0; rlc_series::Signals::NAMES.len()]);
        let r: [f64; rlc_series::RESIDUAL_COUNT] = rlc_series::residuals(&p, &s);
        assert!(r.iter().all(|x| *x == 0.0));
        assert!(rlc_series::candidates(&[false, false]).is_empty());
        assert!(rlc_series::suspects(&[false, false]).is_empty());
    }
}

mod best {
    bondgraph::bond_graph!("../../models/dc_motor.bg", residuals = best);

    #[test]
    fn residuals_best_reaches_every_fault_class() {
        // Four residuals for two detectors: every fault class the structure allows.
        assert_eq!(dc_motor::RESIDUAL_COUNT, 4);
        // A current sensor fault leaves the residual derived without the current quiet.
        assert_eq!(dc_motor::candidates(&[true, true, false, true]), ["i"]);
    }
}

mod fitted {
    bondgraph::bond_graph!(
        "../../models/dc_motor.bg",
        params = "tests/fixtures/dc_motor_fitted.params"
    );

    #[test]
    fn a_parameter_file_replaces_the_models_values() {
        let p = dc_motor::Params::default();
        assert_eq!((p.Re, p.fe), (0.36, 0.12));
        // The others keep the model's.
        assert_eq!((p.L, p.ke, p.Je), (0.5, 0.5, 0.8));
    }
}

mod direct {
    bondgraph::bond_graph!("../../models/dc_motor.bg", realise = direct);

    #[test]
    fn realised_as_written_the_residuals_read_derivatives() {
        assert_eq!(dc_motor::INTEGRATED, [false, false]);
        assert_eq!(dc_motor::RAW_ORDERS, [0, 1, 1]);
        let p = dc_motor::Params::default();
        // At rest with the current that holds the motor's friction: U0 = Re i + ke y1.
        let s = dc_motor::Signals {
            U0: 0.3 * 0.2 + 0.5 * 1.0,
            i: 0.2,
            i_d1: 0.0,
            y1: 1.0,
            y1_d1: 0.0,
        };
        let r = dc_motor::residuals(&p, &s);
        assert!(r[0].abs() < 1e-15, "{r:?}");
        assert!((r[1] - (0.5 * 0.2 - 0.1 * 1.0)).abs() < 1e-15, "{r:?}");
    }
}

mod inline {
    bondgraph::bond_graph! {
        # An RC circuit driven by a current source.
        model rc
        param R1 = 2 [Ohm] "resistance"
        param C1 = 0.5 [F]   // Rust's comments are the model's too
        input I0 [A]
        Sf src = I0
        R res = R1
        C cap = C1
        De v on n "capacitor voltage"
        src -> 0:n -> res, cap
    }

    #[test]
    fn an_inline_model_is_realised_by_integration() {
        // Realised by integration: the running value -C1 v + int(I0) - int(v)/R1.
        assert_eq!(rc::INTEGRATED, [true]);
        let p = rc::Params {
            R1: 4.0,
            ..rc::Params::default()
        };
        let s = rc::Signals {
            I0_int: 3.0,
            v: 4.0,
            v_int: 4.0,
        };
        assert_eq!(rc::residuals(&p, &s), [0.0]);
    }
}
