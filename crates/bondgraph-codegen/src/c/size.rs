//! A fault's size in C: one parameter's value estimated sample by sample from two copies of
//! the generator (the runtime's `FaultSize`, the same operations in the same order), and the
//! parameters set by place that it needs.

use std::fmt::Write as _;

use super::context::{dim, Context};
use crate::c::names::ident;

/// The size estimator's type.
pub(super) fn types(cx: &Context<'_>) -> String {
    let n = cx.names;
    format!(
        "/* A fault's size: one parameter's value estimated sample by sample, as the Rust runtime's
   FaultSize estimates it, from two copies of the generator (at the value it linearises
   around and a small step away: their difference is the residuals' sensitivity), by
   recursive least squares with forgetting. Set it up with _size_init; its fields are its
   own. */
typedef struct {{
    {g} base, probe;
    double weights[{r}];
    bgc_change change;
    int parameter, settling, skip;
    double point, step;
    bgc_size held;
}} {s};

",
        g = n.f("generator"),
        s = n.f("size"),
        r = dim(cx.residuals()),
    )
}

/// The prototypes of the parameters by place and of the size estimator.
pub(super) fn prototypes(cx: &Context<'_>) -> String {
    let n = cx.names;
    format!(
        "
/* Parameter k's value in g, in the order of _parameter_names (NAN where there is none). */
double {get}(const {g} *g, int k);

/* Sets parameter k of g; the generator keeps its estimators' and integrals' state. */
int {set}({g} *g, int k, double value);

/* Sets s up to size parameter `parameter` of `generator` (set up with _init and the _set_
   functions and not yet pushed: it is copied), on residuals of healthy RMS noise[k] (or their
   thresholds over 3), forgetting with a time constant of `memory` samples of typical
   information. Correlation 1 sample and settling 250 samples, as the Rust runtime's
   FaultSize::new. Returns BGC_OK or what is wrong. */
int {init}({s} *s, const {g} *generator, int parameter, const double noise[{r}], int memory);

/* Successive residuals are correlated over `samples` samples (the estimator's window): the
   interval widens by its square root. */
void {corr}({s} *s, int samples);

/* After the point linearised around moves, the residuals are left out for `samples`
   samples (the integration window: an integrated residual holds values of the old point
   until it has passed). */
void {settle}({s} *s, int samples);

/* Takes one sample of the raw signals at t (as _push takes it). */
void {push}({s} *s, double t, const double raw[{raw}]);

/* The last informative estimate: the parameter's value once its interval is within a tenth
   of it (the model's value, with HUGE_VAL half-width and misfit, until then). */
bgc_size {estimate}(const {s} *s);
",
        g = n.f("generator"),
        s = n.f("size"),
        get = n.f("parameter"),
        set = n.f("set_parameter"),
        init = n.f("size_init"),
        corr = n.f("size_set_correlation"),
        settle = n.f("size_set_settling"),
        push = n.f("size_push"),
        estimate = n.f("size_estimate"),
        r = dim(cx.residuals()),
        raw = dim(cx.program.raw.len()),
    )
}

/// The functions: parameters by place, then the size estimator's.
pub(super) fn functions(cx: &Context<'_>) -> String {
    let mut s = by_place(cx);
    s += &estimator(cx);
    s
}

/// `_parameter` and `_set_parameter`: a switch on the place.
fn by_place(cx: &Context<'_>) -> String {
    let n = cx.names;
    let (mut get, mut set) = (String::new(), String::new());
    for (k, p) in cx.c.parameters.values().enumerate() {
        let field = ident(&p.name);
        let _ = writeln!(get, "    case {k}:\n        return g->params.{field};");
        let _ = writeln!(
            set,
            "    case {k}:\n        g->params.{field} = value;\n        return BGC_OK;"
        );
    }
    format!(
        "
double {getf}(const {g} *g, int k)
{{
    switch (k) {{
{get}    default:
        (void)g;
        return NAN;
    }}
}}

int {setf}({g} *g, int k, double value)
{{
    switch (k) {{
{set}    default:
        (void)g;
        (void)value;
        return BGC_BAD_PARAMETER;
    }}
}}
",
        g = n.f("generator"),
        getf = n.f("parameter"),
        setf = n.f("set_parameter"),
    )
}

/// The size estimator: set-up, `push` (with its hold and follow steps) and the estimate.
fn estimator(cx: &Context<'_>) -> String {
    let n = cx.names;
    format!(
        "
int {init}({s} *s, const {g} *generator, int parameter, const double noise[{r_dim}], int memory)
{{
    int k;
    if (parameter < 0 || parameter >= {count})
        return BGC_BAD_PARAMETER;
    if (memory < 2)
        return BGC_BAD_MEMORY;
    for (k = 0; k < {r}; k++) {{
        if (!(isfinite(noise[k]) && noise[k] > 0.0))
            return BGC_BAD_NOISE;
        s->weights[k] = 1.0 / (noise[k] * noise[k]);
    }}
    s->parameter = parameter;
    s->point = {get}(generator, parameter);
    s->step = bgc_size_step(s->point);
    s->base = *generator;
    s->probe = *generator;
    {set}(&s->base, parameter, s->point);
    {set}(&s->probe, parameter, s->point + s->step);
    bgc_change_start(&s->change, memory);
    s->settling = 250;
    s->skip = 0;
    s->held.value = s->point;
    s->held.half_width = HUGE_VAL;
    s->held.misfit = HUGE_VAL;
    return BGC_OK;
}}

void {corr}({s} *s, int samples)
{{
    s->change.correlation = samples > 1 ? (double)samples : 1.0;
}}

void {settle}({s} *s, int samples)
{{
    s->settling = samples > 0 ? samples : 0;
}}

/* The parameter's scale: its value where it is not 0. */
static double {scale}(const {s} *s)
{{
    return s->point == 0.0 ? s->step / 1e-4 : fabs(s->point);
}}

/* Keeps the estimate when it is informative: its interval within a tenth of the parameter's
   scale, from several correlation lengths and a tenth of a memory of samples at least. */
static void {hold}({s} *s)
{{
    double delta, half_width, misfit, samples, enough;
    double memory = 1.0 / (1.0 - s->change.forgetting);
    if (!bgc_change_get(&s->change, {r}, &delta, &half_width, &misfit, &samples))
        return;
    enough = 4.0 * s->change.correlation;
    if (0.1 * memory > enough)
        enough = 0.1 * memory;
    if (samples >= enough && half_width <= 0.1 * {scale}(s) && isfinite(delta)) {{
        s->held.value = s->point + delta;
        s->held.half_width = half_width;
        s->held.misfit = misfit;
    }}
}}

/* Moves the point linearised around to the estimate once that has gone further than 5 %,
   further than its interval, on half a memory of samples; the copies go on at it. */
static void {follow}({s} *s)
{{
    double delta, half_width, misfit, samples, scale;
    double memory = 1.0 / (1.0 - s->change.forgetting);
    if (!bgc_change_get(&s->change, {r}, &delta, &half_width, &misfit, &samples))
        return;
    scale = {scale}(s);
    if (samples >= 0.5 * memory && fabs(delta) > 0.05 * scale && fabs(delta) > half_width &&
        isfinite(delta)) {{
        s->point += delta;
        s->step = bgc_size_step(s->point);
        {set}(&s->base, s->parameter, s->point);
        {set}(&s->probe, s->parameter, s->point + s->step);
        bgc_change_reset(&s->change);
        s->skip = s->settling;
    }}
}}

void {push}({s} *s, double t, const double raw[{raw}])
{{
    {out} base, probe;
    double sensitivities[{r_dim}];
    int k, a = {push_g}(&s->base, t, raw, &base), b = {push_g}(&s->probe, t, raw, &probe);
    if (!(a && b))
        return;
    if (s->skip > 0) {{
        s->skip--;
        return;
    }}
    for (k = 0; k < {r}; k++)
        sensitivities[k] = (probe.residuals[k] - base.residuals[k]) / s->step;
    bgc_change_push(&s->change, s->weights, base.residuals, sensitivities, {r});
    {hold}(s);
    {follow}(s);
}}

bgc_size {estimate}(const {s} *s)
{{
    return s->held;
}}
",
        g = n.f("generator"),
        s = n.f("size"),
        out = n.f("output"),
        count = cx.c.parameters.len(),
        get = n.f("parameter"),
        set = n.f("set_parameter"),
        init = n.f("size_init"),
        corr = n.f("size_set_correlation"),
        settle = n.f("size_set_settling"),
        scale = n.f("size_scale"),
        hold = n.f("size_hold"),
        follow = n.f("size_follow"),
        push = n.f("size_push"),
        push_g = n.f("push"),
        estimate = n.f("size_estimate"),
        r = cx.residuals(),
        r_dim = dim(cx.residuals()),
        raw = dim(cx.program.raw.len()),
    )
}
