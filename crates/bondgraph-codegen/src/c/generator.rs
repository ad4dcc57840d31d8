//! The streaming generator in C: its state, its set-up and `push`, as the program says (the
//! same steps as the Rust backend's `ResidualGenerator::push`).

use std::fmt::Write as _;

use bondgraph_core::program::{Evaluation, Fill, Source};

use super::context::{dim, string, Context};
use crate::c::lower::Place;
use crate::c::names::ident;

/// How many of each runtime piece the generator holds.
pub(super) struct Counts {
    /// Trapezoids of raw signals fed to the bank.
    pub(super) integrals: usize,
    /// Trapezoids of nonlinear expressions, integrated at the estimates' instant.
    pub(super) others: usize,
    /// Root finders.
    pub(super) roots: usize,
    /// References of residuals realised by integration.
    pub(super) references: usize,
}

pub(super) fn counts(cx: &Context<'_>) -> Counts {
    let p = cx.program;
    Counts {
        integrals: (p.channels.values())
            .filter(|c| matches!(c.source, Source::Integral(_)))
            .count(),
        others: (p.slots.values())
            .filter(|s| matches!(s.fill, Fill::Integral(_)))
            .count(),
        roots: (p.slots.values())
            .filter(|s| matches!(s.fill, Fill::Root { .. }))
            .count(),
        references: (p.residuals.iter())
            .filter(|r| r.evaluation == Evaluation::Integrated)
            .count(),
    }
}

/// The output and generator types.
pub(super) fn types(cx: &Context<'_>) -> String {
    let n = cx.names;
    let k = counts(cx);
    let r = dim(cx.residuals());
    let ch = dim(cx.program.channels.len());
    let mut h = format!(
        "/* One estimate: its instant (seconds), the residuals, their thresholds (NAN where a residual\n   has none) and alarms (0 or 1). */\ntypedef struct {{\n    double at;\n    double residuals[{r}];\n    double thresholds[{r}];\n    int alarms[{r}];\n}} {};\n\n",
        n.f("output")
    );
    h += "/* A residual generator: raw samples in, residuals out. The raw signals and the\n   trapezoidal integrals the ARRs read go through one Savitzky-Golay bank, so that every\n   term of an ARR is filtered alike and refers to the same instant. Set it up with _init\n   and the _set_ functions; its fields are its own. */\ntypedef struct {\n";
    let _ = writeln!(h, "    {} params;", n.f("params"));
    h += "    int window, next;\n    long seen;\n    double delay;\n";
    h += "    double weights[BGC_MAX_DEGREE + 1][BGC_MAX_WINDOW];\n";
    let _ = writeln!(h, "    double samples[2 * BGC_MAX_WINDOW * {ch}];");
    let _ = writeln!(
        h,
        "    double estimates[{}][{ch}];",
        cx.program.top_order() + 1
    );
    if k.integrals > 0 {
        let _ = writeln!(h, "    bgc_trapezoid integrals[{}];", k.integrals);
    }
    if k.others > 0 {
        let _ = writeln!(h, "    bgc_trapezoid others[{}];", k.others);
    }
    if k.roots > 0 {
        let _ = writeln!(h, "    bgc_root_finder roots[{}];", k.roots);
    }
    h += "    const char *unsolved;\n";
    if k.references > 0 {
        let _ = writeln!(h, "    bgc_reference references[{}];", k.references);
    }
    if let Some(copy) = &cx.program.copy {
        let (s, m) = (dim(copy.rates.len()), dim(copy.inputs.len()));
        let _ = writeln!(
            h,
            "    double copy_x[{s}], copy_now[{s}], copy_k[5 * {s}];\n    double copy_t, copy_u[{m}], copy_mid[{m}];\n    int copy_started, copy_head, copy_len;\n    double copy_ht[BGC_MAX_WINDOW + 2];\n    double copy_hx[(BGC_MAX_WINDOW + 2) * {s}];"
        );
    }
    let _ = writeln!(
        h,
        "    double levels[{r}];\n    bgc_threshold thresholds[{r}];\n    unsigned debounce;\n    int adaptive;"
    );
    let _ = writeln!(
        h,
        "    {} last;\n}} {};\n",
        n.f("signals"),
        n.f("generator")
    );
    h
}

/// The generator's prototypes.
pub(super) fn prototypes(cx: &Context<'_>) -> String {
    let n = cx.names;
    let g = n.f("generator");
    format!(
        "
/* Sets up g over the parameters p for samples `step` seconds apart, with centred
   Savitzky-Golay fits of `degree` (at least {order}) over `window` samples (odd): the
   residuals lag the newest sample by (window - 1)/2 samples. Integrated residuals over the
   last 250 samples, no threshold, debounce 1. Returns BGC_OK or what is wrong. */
int {init}({g} *g, const {p} *p, double step, int window, int degree);

/* Integrated residuals over the last `samples` steps (1 to BGC_MAX_REFERENCE), before the
   first push. */
int {iw}({g} *g, int samples);

/* Integrated residuals from the first estimate, before the first push. */
void {fs}({g} *g);

/* A fixed threshold on |residual| `residual` (NAN: none, no alarm). With adaptive
   thresholds, the margin for noise over the bound. */
int {st}({g} *g, int residual, double level);

/* Consecutive samples above (below) a threshold that raise (clear) its alarm (at least 1). */
void {sd}({g} *g, unsigned samples);

/* Adaptive thresholds (on: 1): each threshold plus the residual's bound from the
   parameters' uncertainty at each estimate; a residual with a bound and no level gets 0. */
void {sa}({g} *g, int on);

/* How far the residuals lag the newest sample, in seconds. */
double {delay}(const {g} *g);

/* Takes the samples of the raw signals at time t (uniform steps) and, once the estimator's
   window is full, writes the estimate at t - delay into out and returns 1; else 0. */
int {push}({g} *g, double t, const double raw[{raw}], {out} *out);

/* The estimates the last residuals were computed from. */
const {sig} *{ls}(const {g} *g);

/* The root that had no solution at the last estimate (its residuals are not numbers
   there), or NULL. */
const char *{un}(const {g} *g);

/* What a status of _init or a _set_ function means. */
const char *{text}(int status);
",
        order = cx.program.top_order(),
        init = n.f("init"),
        p = n.f("params"),
        iw = n.f("set_integration_window"),
        fs = n.f("integrate_from_start"),
        st = n.f("set_threshold"),
        sd = n.f("set_debounce"),
        sa = n.f("set_adaptive"),
        delay = n.f("delay"),
        push = n.f("push"),
        raw = dim(cx.program.raw.len()),
        out = n.f("output"),
        sig = n.f("signals"),
        ls = n.f("last_signals"),
        un = n.f("unsolved"),
        text = n.f("status_text"),
    )
}

/// The copy's rates, when a simulated residual runs a copy of the model.
pub(super) fn copy_rates(cx: &Context<'_>) -> String {
    let Some(copy) = &cx.program.copy else {
        return String::new();
    };
    let mut lower = cx.lowering(Place::Copy);
    let lets = lower.bind_shared(&copy.rates, &[], "t");
    let mut s = format!(
        "/* The copy's rates at time t, states x and inputs u: the model's state equations, then\n   the argument of each int(..) they hold. */\nstatic void {}(const void *params, double t, const double *x, const double *u, double *dx)\n{{\n    const {} *p = params;\n    (void)p;\n    (void)t;\n    (void)x;\n    (void)u;\n",
        cx.names.f("copy_rates"),
        cx.names.f("params")
    );
    for line in lets {
        s += &line;
        s += "\n";
    }
    for (k, &rate) in copy.rates.iter().enumerate() {
        let _ = writeln!(s, "    dx[{k}] = {};", lower.code(rate));
    }
    s + "}\n\n"
}

/// The laws of the roots, set-up, settings and `push`.
pub(super) fn functions(cx: &Context<'_>) -> String {
    let mut s = fits(cx);
    s += &laws(cx);
    s += &setup(cx);
    s += &push(cx);
    s
}

/// The bank's fits, one per number of signals estimated (all of them for the values, the
/// differentiated ones for the derivatives), with the bank's width as a constant, so that the
/// compiler unrolls them as the Rust runtime's const generics are.
fn fits(cx: &Context<'_>) -> String {
    let program = cx.program;
    let width = program.channels.len();
    let mut counts = vec![width];
    if program.top_order() > 0 && program.differentiated != width {
        counts.push(program.differentiated);
    }
    let w = dim(width);
    let mut s = String::new();
    for n in counts {
        let _ = writeln!(
            s,
            "/* The bank's estimates of one order: sum_j w[j] s[j][c] over the window for the first {n}
   of the {width} signals (zero for the others): four running sums per signal over the samples
   in fours, the last samples apart, added as the Rust runtime adds them. */
static void {f}(const double *restrict s, const double *restrict w, int len,
{pad}double *restrict out)
{{
    double s0[{w}], s1[{w}], s2[{w}], s3[{w}], rest[{w}];
    int whole = len / 4 * 4, j, c;
    for (c = 0; c < {w}; c++) {{
        s0[c] = 0.0;
        s1[c] = 0.0;
        s2[c] = 0.0;
        s3[c] = 0.0;
        rest[c] = -0.0;
    }}
    for (j = 0; j < whole; j += 4) {{
        for (c = 0; c < {n}; c++) {{
            s0[c] += w[j] * s[j * {w} + c];
            s1[c] += w[j + 1] * s[(j + 1) * {w} + c];
            s2[c] += w[j + 2] * s[(j + 2) * {w} + c];
            s3[c] += w[j + 3] * s[(j + 3) * {w} + c];
        }}
    }}
    for (j = whole; j < len; j++)
        for (c = 0; c < {n}; c++)
            rest[c] += s[j * {w} + c] * w[j];
    for (c = 0; c < {w}; c++)
        out[c] = (s0[c] + s1[c]) + (s2[c] + s3[c]) + rest[c];
}}
",
            f = cx.names.f(&format!("fit{n}")),
            pad = " ".repeat(cx.names.f(&format!("fit{n}")).len() + 13),
        );
    }
    s
}

/// One function per root: the law's value and slope at `z`, with the slots before it.
fn laws(cx: &Context<'_>) -> String {
    let n = cx.names;
    let mut s = String::new();
    let mut k = 0;
    for f in cx.fields {
        let Fill::Root { residual, slope } = cx.program.slots[f.slot].fill else {
            continue;
        };
        if k == 0 {
            let _ = writeln!(
                s,
                "/* What a law reads besides its root. */\nstruct {} {{\n    const {} *p;\n    {} *s;\n    double at;\n}};\n",
                n.f("law_context"),
                n.f("params"),
                n.f("signals")
            );
        }
        let mut lower = cx.lowering(Place::Push);
        let lets = lower.bind_shared(&[residual, slope], &[], "e");
        let lets: String = lets.iter().map(|l| format!("{l}\n")).collect();
        let _ = writeln!(
            s,
            "/* The law whose root is `{name}`. */\nstatic void {f}(void *context, double z, double *value, double *slope)\n{{\n    const struct {lc} *law = context;\n    const {p} *p = law->p;\n    {sig} *s = law->s;\n    const double at = law->at;\n    (void)p;\n    (void)at;\n    s->{field} = z;\n{lets}    *value = {v};\n    *slope = {d};\n}}\n",
            name = f.name,
            f = n.f(&format!("law{k}")),
            lc = n.f("law_context"),
            p = n.f("params"),
            sig = n.f("signals"),
            field = ident(&f.name),
            v = lower.code(residual),
            d = lower.code(slope),
        );
        k += 1;
    }
    s
}

/// `_init`, the settings and the small accessors.
fn setup(cx: &Context<'_>) -> String {
    let n = cx.names;
    let k = counts(cx);
    let g = n.f("generator");
    let mut init = String::new();
    if k.integrals > 0 {
        let _ = writeln!(
            init,
            "    for (k = 0; k < {}; k++)\n        g->integrals[k] = zero;",
            k.integrals
        );
    }
    if k.others > 0 {
        let _ = writeln!(
            init,
            "    for (k = 0; k < {}; k++)\n        g->others[k] = zero;",
            k.others
        );
    }
    if k.roots > 0 {
        let _ = writeln!(
            init,
            "    for (k = 0; k < {}; k++) {{\n        g->roots[k].found = 0;\n        g->roots[k].last = 0.0;\n        g->roots[k].failures = 0;\n    }}",
            k.roots
        );
    }
    if let Some(copy) = &cx.program.copy {
        let _ = writeln!(
            init,
            "    for (k = 0; k < {}; k++)\n        g->copy_x[k] = 0.0;\n    g->copy_started = 0;\n    g->copy_head = 0;\n    g->copy_len = 0;",
            copy.rates.len()
        );
    }
    let references = if k.references > 0 {
        format!(
            "    int k;\n    for (k = 0; k < {}; k++) {{\n        g->references[k].samples = samples;\n        g->references[k].next = 0;\n        g->references[k].seen = 0;\n    }}\n",
            k.references
        )
    } else {
        "    (void)g;\n    (void)samples;\n".to_string()
    };
    format!(
        "const char *{text}(int status)
{{
    switch (status) {{
    case BGC_OK: return \"ok\";
    case BGC_BAD_STEP: return \"the step is not a positive finite number of seconds\";
    case BGC_BAD_DEGREE: return \"the degree is below the highest derivative the ARRs read ({order}) or above BGC_MAX_DEGREE\";
    case BGC_BAD_WINDOW: return \"the window is even, not longer than the degree, or longer than BGC_MAX_WINDOW\";
    case BGC_SINGULAR_FIT: return \"the fit's normal equations are singular\";
    case BGC_BAD_INTEGRATION_WINDOW: return \"the integration window is not between 1 and BGC_MAX_REFERENCE samples\";
    case BGC_BAD_INDEX: return \"no residual has that index\";
    case BGC_BAD_PARAMETER: return \"no parameter has that index\";
    case BGC_BAD_NOISE: return \"a residual's noise level is not a positive number (its healthy RMS, or its threshold over 3)\";
    case BGC_BAD_MEMORY: return \"a size estimate's memory is shorter than 2 samples\";
    default: return \"not a status this code returns\";
    }}
}}

static void {references}({g} *g, int samples)
{{
{refs}}}

int {init}({g} *g, const {p} *p, double step, int window, int degree)
{{
    static const bgc_trapezoid zero = {{0.0, 0.0, 0.0, 0}};
    static const {sig} no_signals;
    int k;
    (void)zero;
    if (!(isfinite(step) && step > 0.0))
        return BGC_BAD_STEP;
    if (degree < {order} || degree > BGC_MAX_DEGREE)
        return BGC_BAD_DEGREE;
    if (window <= degree || window % 2 == 0 || window > BGC_MAX_WINDOW)
        return BGC_BAD_WINDOW;
    if (!bgc_fit_weights({order}, degree, window, (window - 1) / 2, step, g->weights))
        return BGC_SINGULAR_FIT;
    g->params = *p;
    g->window = window;
    g->next = 0;
    g->seen = 0;
    g->delay = (double)(window - 1 - (window - 1) / 2) * step;
    g->unsolved = NULL;
{init_body}    {references}(g, 250);
    for (k = 0; k < {r}; k++) {{
        g->levels[k] = NAN;
        g->thresholds[k].count = 0;
        g->thresholds[k].alarm = 0;
    }}
    g->debounce = 1;
    g->adaptive = 0;
    g->last = no_signals;
    return BGC_OK;
}}

int {iw}({g} *g, int samples)
{{
    if (samples < 1 || samples > BGC_MAX_REFERENCE)
        return BGC_BAD_INTEGRATION_WINDOW;
    {references}(g, samples);
    return BGC_OK;
}}

void {fs}({g} *g)
{{
    {references}(g, 0);
}}

int {st}({g} *g, int residual, double level)
{{
    if (residual < 0 || residual >= {residuals})
        return BGC_BAD_INDEX;
    g->levels[residual] = level;
    return BGC_OK;
}}

void {sd}({g} *g, unsigned samples)
{{
    g->debounce = samples < 1u ? 1u : samples;
}}

void {sa}({g} *g, int on)
{{
    g->adaptive = on != 0;
}}

double {delay}(const {g} *g)
{{
    return g->delay;
}}

const {sig} *{ls}(const {g} *g)
{{
    return &g->last;
}}

const char *{un}(const {g} *g)
{{
    return g->unsolved;
}}

",
        text = n.f("status_text"),
        order = cx.program.top_order(),
        references = n.f("reset_references"),
        refs = references,
        init = n.f("init"),
        p = n.f("params"),
        sig = n.f("signals"),
        init_body = init,
        r = dim(cx.residuals()),
        residuals = cx.residuals(),
        iw = n.f("set_integration_window"),
        fs = n.f("integrate_from_start"),
        st = n.f("set_threshold"),
        sd = n.f("set_debounce"),
        sa = n.f("set_adaptive"),
        delay = n.f("delay"),
        ls = n.f("last_signals"),
        un = n.f("unsolved"),
    )
}

/// `_push`: the copy, the bank, the slots, the residuals, their references and alarms.
fn push(cx: &Context<'_>) -> String {
    let (n, program) = (cx.names, cx.program);
    let ch = program.channels.len();
    let mut s = format!(
        "int {}({} *g, double t, const double raw[{}], {} *out)\n{{\n",
        n.f("push"),
        n.f("generator"),
        dim(program.raw.len()),
        n.f("output")
    );
    let _ = writeln!(
        s,
        "    static const {sig} no_signals;\n    {sig} signals = no_signals, *s = &signals;\n    const {p} *p = &g->params;\n    double x[{ch1}], bound[{r}], at;\n    const double *window;\n    int k;\n    (void)raw;\n    (void)p;\n    (void)s;",
        sig = n.f("signals"),
        p = n.f("params"),
        ch1 = dim(ch),
        r = dim(cx.residuals()),
    );
    if let Some(copy) = &program.copy {
        let inputs: Vec<String> = (copy.inputs.iter())
            .map(|h| format!("raw[{}]", h.index()))
            .collect();
        let u = if inputs.is_empty() {
            "0.0".to_string()
        } else {
            inputs.join(", ")
        };
        let (states, m) = (copy.rates.len(), copy.inputs.len());
        let _ = writeln!(
            s,
            "    {{\n        /* The copy of the model steps to t on the raw inputs. */\n        const double u[{dm}] = {{{u}}};\n        int i, last;\n        if (g->copy_started)\n            bgc_rk4({rates}, &g->params, g->copy_t, t - g->copy_t, g->copy_u, u, {m}, g->copy_mid, g->copy_x, {states}, g->copy_k);\n        g->copy_t = t;\n        for (i = 0; i < {m}; i++)\n            g->copy_u[i] = u[i];\n        g->copy_started = 1;\n        if (g->copy_len == BGC_MAX_WINDOW + 2) {{\n            g->copy_head = (g->copy_head + 1) % (BGC_MAX_WINDOW + 2);\n            g->copy_len--;\n        }}\n        last = (g->copy_head + g->copy_len) % (BGC_MAX_WINDOW + 2);\n        g->copy_ht[last] = t;\n        for (i = 0; i < {states}; i++)\n            g->copy_hx[last * {states} + i] = g->copy_x[i];\n        g->copy_len++;\n    }}",
            dm = dim(m),
            rates = n.f("copy_rates"),
        );
    }
    let mut integrals = 0usize;
    for (h, channel) in program.channels.iter() {
        match channel.source {
            Source::Raw(k) => {
                let _ = writeln!(s, "    x[{}] = raw[{}];", h.index(), k.index());
            }
            Source::Integral(k) => {
                let _ = writeln!(
                    s,
                    "    x[{}] = bgc_trapezoid_push(&g->integrals[{integrals}], t, raw[{}]);",
                    h.index(),
                    k.index()
                );
                integrals += 1;
            }
        }
    }
    let _ = writeln!(
        s,
        "    at = t - g->delay;
    /* Each sample twice, `window` apart: the last `window` samples are one run, oldest first. */
    for (k = 0; k < {ch}; k++) {{
        g->samples[g->next * {ch1} + k] = x[k];
        g->samples[(g->next + g->window) * {ch1} + k] = x[k];
    }}
    g->next = g->next + 1 == g->window ? 0 : g->next + 1;
    if (g->seen < g->window)
        g->seen++;
    if (g->seen < g->window)
        return 0;
    window = g->samples + g->next * {ch1};
    {fit_all}(window, g->weights[0], g->window, g->estimates[0]);",
        ch1 = dim(ch),
        fit_all = n.f(&format!("fit{ch}")),
    );
    if program.top_order() > 0 {
        let _ = writeln!(
            s,
            "    for (k = 1; k <= {}; k++)\n        {}(window, g->weights[k], g->window, g->estimates[k]);",
            program.top_order(),
            n.f(&format!("fit{}", program.differentiated)),
        );
    }
    if let Some(copy) = &program.copy {
        let _ = writeln!(
            s,
            "    if (!bgc_replay_at(g->copy_ht, g->copy_hx, {}, BGC_MAX_WINDOW + 2, &g->copy_head, &g->copy_len, at, g->copy_now))\n        return 0;",
            copy.rates.len()
        );
    }
    s += "    g->unsolved = NULL;\n";
    s += &fills(cx);
    let refs: Vec<usize> = (program.residuals.iter().enumerate())
        .filter(|(_, r)| r.evaluation == Evaluation::Integrated)
        .map(|(k, _)| k)
        .collect();
    let _ = writeln!(s, "    {}(p, s, out->residuals);", n.f("residuals"));
    for (j, k) in refs.iter().enumerate() {
        let _ = writeln!(
            s,
            "    out->residuals[{k}] = bgc_reference_push(&g->references[{j}], out->residuals[{k}]);"
        );
    }
    let _ = writeln!(
        s,
        "    g->last = signals;
    out->at = at;
    for (k = 0; k < {r}; k++)
        bound[k] = 0.0;
    if (g->adaptive)
        {bounds}(p, &{unc}, s, bound);
    for (k = 0; k < {residuals}; k++) {{
        double level = g->levels[k], threshold, r = out->residuals[k];
        if (g->adaptive && level != level && {has}[k])
            level = 0.0;
        threshold = level + bound[k];
        /* No level, or a bound past the largest double: no threshold. */
        if (!isfinite(threshold))
            threshold = NAN;
        out->thresholds[k] = threshold;
        /* A residual that is not a number says nothing: no alarm, the debounce waits. */
        out->alarms[k] = threshold == threshold && isfinite(r)
            ? bgc_threshold_update(&g->thresholds[k], r, threshold, g->debounce)
            : 0;
    }}
    return 1;
}}
",
        r = dim(cx.residuals()),
        residuals = cx.residuals(),
        bounds = n.f("bounds"),
        unc = n.f("uncertainty"),
        has = n.f("has_bound"),
    );
    s
}

/// How each field is filled, in the program's order.
fn fills(cx: &Context<'_>) -> String {
    let (n, program) = (cx.names, cx.program);
    let (mut others, mut roots) = (0usize, 0usize);
    let mut s = String::new();
    for f in cx.fields {
        let name = ident(&f.name);
        match program.slots[f.slot].fill {
            Fill::Estimate { channel, order } => {
                let _ = writeln!(
                    s,
                    "    s->{name} = g->estimates[{order}][{}];",
                    channel.index()
                );
            }
            Fill::Simulated(k) => {
                let _ = writeln!(s, "    s->{name} = g->copy_now[{}];", k.index());
            }
            Fill::Integral(integrand) => {
                // Each fill's repeated parts are computed once, in a block of its own.
                let mut lower = cx.lowering(Place::Push);
                let lets = lower.bind_shared(&[integrand], &[], "e");
                let fill = format!(
                    "s->{name} = bgc_trapezoid_push(&g->others[{others}], at, {});",
                    lower.code(integrand)
                );
                if lets.is_empty() {
                    let _ = writeln!(s, "    {fill}");
                } else {
                    let _ = writeln!(s, "    {{");
                    for line in lets {
                        let _ = writeln!(s, "    {line}");
                    }
                    let _ = writeln!(s, "        {fill}\n    }}");
                }
                others += 1;
            }
            Fill::Root { .. } => {
                let _ = writeln!(
                    s,
                    "    {{\n        struct {lc} law = {{p, s, at}};\n        double z;\n        if (bgc_root_solve(&g->roots[{roots}], {f}, &law, &z))\n            s->{name} = z;\n        else {{\n            s->{name} = NAN;\n            if (g->unsolved == NULL)\n                g->unsolved = {label};\n        }}\n    }}",
                    lc = n.f("law_context"),
                    f = n.f(&format!("law{roots}")),
                    label = string(&f.name),
                );
                roots += 1;
            }
        }
    }
    s
}
