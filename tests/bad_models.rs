//! Every model in `tests/bad/` is rejected with exit code 1, and its diagnostics, which must
//! name the file, line and column, are snapshotted.

use crate::common::{bgc, code, names_line_and_column, relative, stdout};

#[test]
fn every_bad_model_is_rejected_with_a_located_diagnostic() {
    insta::glob!("bad/*.bg", |path| {
        let model = relative(path);
        let out = bgc(&["check", &model]);
        // As the user sees it, wrapped lines and all.
        let report = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(code(&out), 1, "{model}: {report}");
        assert!(
            stdout(&out).is_empty(),
            "{model}: printed a summary for an invalid model"
        );
        let has_line_col = names_line_and_column(&report, &model);
        assert!(has_line_col, "{model}: no file:line:col in\n{report}");
        insta::assert_snapshot!("diagnostics", report);
    });
}
